#!/usr/bin/env bash
# Builds the libFuzzer target fuzz_node_message with clang (ASan + libFuzzer, in
# build-fuzz/, apart from the normal build) and runs it for SECONDS on a copy of
# the seed corpus fuzz/corpus/. A crash, leak or sanitizer report exits non-zero
# and leaves the reproducer in build-fuzz/artifacts/.
# Usage: scripts/fuzz.sh SECONDS          run for SECONDS (1..86400)
#        scripts/fuzz.sh --seeds          regenerate fuzz/corpus/ from real client sessions
set -euo pipefail
cd "$(dirname "$0")/.."
arg=${1:-}
case "$arg" in
  --seeds) ;;
  ''|*[!0-9]*) echo "usage: scripts/fuzz.sh SECONDS | --seeds" >&2; exit 2 ;;
  *) if [ "$arg" -lt 1 ] || [ "$arg" -gt 86400 ]; then echo "fuzz: SECONDS in 1..86400" >&2; exit 2; fi ;;
esac
command -v clang >/dev/null || { echo "fuzz: clang not installed (apt-get install clang)" >&2; exit 1; }
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
CC=clang CXX=clang++ cmake -S . -B build-fuzz "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCORVID_FUZZ=ON \
  -DCORVID_WERROR=OFF -DBUILD_TESTING=OFF -DCORVID_BUILD_BENCH=OFF >/dev/null
cmake --build build-fuzz --target fuzz_node_message make_corpus --parallel "$(nproc)"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
# Leaks in a session are the node's leaks: report them (libFuzzer's -detect_leaks is on by default).
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1}
if [ "$arg" = "--seeds" ]; then
  rm -f fuzz/corpus/*.bin
  build-fuzz/fuzz/make_corpus fuzz/corpus
  exit 0
fi
work=build-fuzz/corpus
mkdir -p "$work" build-fuzz/artifacts
cp -n fuzz/corpus/* "$work"/ 2>/dev/null || true
echo "fuzz: fuzz_node_message for $arg s on $(find "$work" -type f | wc -l) inputs (seeds: fuzz/corpus/)"
build-fuzz/fuzz/fuzz_node_message -max_total_time="$arg" -max_len=65536 -timeout=20 -rss_limit_mb=4096 \
  -print_final_stats=1 -artifact_prefix=build-fuzz/artifacts/ "$work"
echo "fuzz: no crash in $arg s"
