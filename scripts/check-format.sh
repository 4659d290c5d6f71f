#!/usr/bin/env bash
# Exits non-zero when a C source differs from .clang-format (clang-format 14
# --dry-run -Werror over the files scripts/format.sh formats); names them.
set -euo pipefail
exec bash "$(dirname "$0")/format.sh" --check
