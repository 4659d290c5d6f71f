#!/usr/bin/env bash
# The README's test command: installs missing dependencies, builds, and runs
# the whole test suite with ctest (Vulkan tests on lavapipe, validation on).
# Usage: scripts/test.sh [--sanitize]   (ASan+UBSan build in build-asan/)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-deps.sh
bash scripts/build.sh "$@"
build_dir=build
[ "${1:-}" = "--sanitize" ] && build_dir=build-asan
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
# Sanitizer runs: lavapipe's LLVM JIT and the loader are not instrumented; leaks
# inside the driver are theirs, ours are still reported through suppressions-free ASan.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
ctest --test-dir "$build_dir" --output-on-failure --parallel 2 --timeout 600
