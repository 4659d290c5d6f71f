#!/usr/bin/env bash
# The README's test command: installs missing dependencies, builds, and runs
# the whole test suite with ctest (Vulkan tests on lavapipe, validation on).
# Usage: scripts/test.sh [--sanitize | --tsan | --release | --clang]
#   --sanitize  the whole suite under ASan+UBSan (build-asan/)
#   --tsan      the tests labelled "threaded" under ThreadSanitizer (build-tsan/);
#               tests/CMakeLists.txt says how a test joins that label
#   --release, --clang  the whole suite in that build (scripts/build.sh lists them)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-deps.sh
bash scripts/build.sh "$@"
build_dir=build
ctest_args=()
run=()
case "${1:-}" in
  --sanitize) build_dir=build-asan ;;
  --release) build_dir=build-release ;;
  --clang) build_dir=build-clang ;;
  --tsan)
    build_dir=build-tsan
    ctest_args=(--label-regex '^threaded$')
    # Third-party libraries only (lavapipe); tests/tsan.supp says why.
    export TSAN_OPTIONS=${TSAN_OPTIONS:-suppressions=$PWD/tests/tsan.supp:second_deadlock_stack=1}
    # GCC 12's TSan runtime aborts ("unexpected memory mapping") on kernels with
    # more mmap randomization than it knows; without ASLR it runs anywhere.
    command -v setarch >/dev/null && setarch "$(uname -m)" -R true 2>/dev/null && run=(setarch "$(uname -m)" -R)
    ;;
esac
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
# Sanitizer runs: lavapipe's LLVM JIT and the loader are not instrumented; leaks
# inside the driver are theirs, ours are still reported through suppressions-free ASan.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
"${run[@]}" ctest --test-dir "$build_dir" --output-on-failure --parallel 2 --timeout 600 "${ctest_args[@]}"
