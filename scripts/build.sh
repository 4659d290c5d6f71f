#!/usr/bin/env bash
# Configures and builds Corvid, warnings as errors (CORVID_WERROR=ON; a plain
# cmake build leaves it off). Ninja when installed, else CMake's default.
# Usage: scripts/build.sh [MODE] [extra cmake -D options...]
#   (none)      build/          RelWithDebInfo
#   --sanitize  build-asan/     AddressSanitizer + UndefinedBehaviorSanitizer (Debug)
#   --tsan      build-tsan/     ThreadSanitizer (RelWithDebInfo)
#   --release   build-release/  Release (-O3) with CMake's default generator, as a
#                               user's plain `cmake -DCMAKE_BUILD_TYPE=Release` builds
#   --clang     build-clang/    RelWithDebInfo compiled by clang (CC=clang)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=build
options=(-DCMAKE_BUILD_TYPE=RelWithDebInfo)
case "${1:-}" in
  --sanitize)
    shift
    build_dir=build-asan
    options=(-DCMAKE_BUILD_TYPE=Debug -DCORVID_SANITIZE=ON -DCORVID_BUILD_BENCH=OFF)
    ;;
  --tsan)
    shift
    build_dir=build-tsan
    options=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DCORVID_SANITIZE_THREAD=ON -DCORVID_BUILD_BENCH=OFF)
    ;;
  --release)
    shift
    build_dir=build-release
    options=(-DCMAKE_BUILD_TYPE=Release)
    ;;
  --clang)
    shift
    build_dir=build-clang
    export CC=clang CXX=clang++
    ;;
esac
generator=()
[ "$build_dir" != build-release ] && command -v ninja >/dev/null && generator=(-G Ninja)
cmake -S . -B "$build_dir" "${generator[@]}" "${options[@]}" -DCORVID_WERROR=ON "$@" >/dev/null
cmake --build "$build_dir" --parallel "$(nproc)"
echo "build: $build_dir ready"
