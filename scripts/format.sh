#!/usr/bin/env bash
# Formats Corvid's C sources in place with clang-format 14 and the tree's
# .clang-format. Files: every *.c and *.h that git tracks or would track
# (outside git: found under the repository), except shaders/ and build trees.
# Usage: scripts/format.sh [--check | --list]
#   --check  change nothing; exit 1 and name the files that are not formatted
#            (scripts/check-format.sh, the first step of .ci/run)
#   --list   print the files it would format
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-format}

list_files() {
  if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    git ls-files --cached --others --exclude-standard -- '*.c' '*.h' | grep -v '^shaders/' || true
  else
    find . \( -path './.*' -o -path './build*' -o -path './out' -o -path './shaders' \) -prune \
      -o -type f \( -name '*.c' -o -name '*.h' \) -print | sed 's|^\./||' | sort
  fi
}

# Another major version formats differently: insist on 14 (Debian 12's clang-format).
clang_format=${CLANG_FORMAT:-}
if [ -z "$clang_format" ]; then
  for c in clang-format-14 clang-format; do
    if command -v "$c" >/dev/null; then clang_format=$c; break; fi
  done
fi
if [ "$mode" != --list ]; then
  [ -f .clang-format ] || { echo "format: no .clang-format at the top of the tree" >&2; exit 2; }
  if [ -z "$clang_format" ] || ! "$clang_format" --version | grep -q 'version 14\.'; then
    echo "format: needs clang-format 14 (scripts/setup-deps.sh installs it; CLANG_FORMAT=path picks one)" >&2
    exit 2
  fi
fi

case "$mode" in
  --list) list_files ;;
  --check)
    # One run over all files: --ferror-limit=1 stops at the first difference of each file.
    rc=0
    out=$(list_files | xargs -r "$clang_format" --style=file --dry-run -Werror --ferror-limit=1 2>&1) || rc=$?
    bad=$(printf '%s\n' "$out" | sed -n 's/^\(.*\):[0-9]*:[0-9]*: error: code should be clang-formatted.*/\1/p' | sort -u)
    if [ -n "$bad" ]; then
      echo "format: $(echo "$bad" | wc -l) file(s) differ from .clang-format; scripts/format.sh fixes them:" >&2
      echo "$bad" | sed 's/^/  /' >&2
      exit 1
    fi
    if [ $rc -ne 0 ]; then
      printf '%s\n' "$out" >&2
      echo "format: $clang_format failed (exit $rc)" >&2
      exit 1
    fi
    echo "format: $(list_files | wc -l) files formatted"
    ;;
  format) list_files | xargs -r -n 16 -P 2 "$clang_format" --style=file -i ;;
  *) echo "usage: scripts/format.sh [--check | --list]" >&2; exit 2 ;;
esac
