#!/bin/sh
# The trace paths on the NVIDIA machine: run from the repository root through
# the device tool, with the prebuilt build carried as for bench/nvidia_tests.sh
# (.carry/b.tar.gz holding bin/ and lib/, the Vulkan loader and validation
# layer as .gl/*.deb; bench/nvidia_env.sh unpacks them, points the loader at
# NVIDIA's ICD and sets LD_LIBRARY_PATH to the carried lib/).
#
#   bench/run_nvidia.sh [tests|bench|all] [bench_trace options...]
#
# tests: trace_paths and vk_trace (both trace paths against the CPU reference,
#        validation layer on) -> $OUT/trace_tests.log
# bench: bench_trace with the GPU defaults (2048x2048 primary rays, 0.5 s of
#        warm-up before each measurement, both paths, Embree off) plus any
#        options given -> $OUT/bench_trace.log
# all (the default): both, tests first.
# Each part has its own time limit so that one command stays within the
# device tool's ten minutes.
set -u
what=${1:-all}
[ $# -gt 0 ] && shift
case "$what" in
  tests|bench|all) ;;
  *) echo "usage: bench/run_nvidia.sh [tests|bench|all] [bench_trace options...]" >&2; exit 2 ;;
esac

. bench/nvidia_env.sh
cd /tmp/corvid/b/bin || exit 1

status=0
if [ "$what" != bench ]; then
  {
    nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv,noheader
    for t in trace_paths vk_trace; do
      echo "== $t"
      timeout 240 ./$t
      echo "== $t exit $?"
    done
  } > "$OUT/trace_tests.log" 2>&1
  grep -E "^== |passed|failed|wrong|measured" "$OUT/trace_tests.log"
  grep -q "exit [^0]" "$OUT/trace_tests.log" && status=1
fi
if [ "$what" != tests ]; then
  timeout 330 ./bench_trace "$@" > "$OUT/bench_trace.log" 2>&1 || status=1
  cat "$OUT/bench_trace.log"
fi
exit $status
