#!/usr/bin/env bash
# On the NVIDIA device machine: the tests (bench/nvidia_tests.sh), then
# bench_node on the GPU (local render vs the same render through a corvid-node
# on loopback, result stream, uploads, latency through a delaying relay),
# logging to $OUT/node-bench.log.
bash bench/nvidia_tests.sh
. bench/nvidia_env.sh
cd /tmp/corvid/b/bin
{ nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
  timeout 300 ./bench_node --adapter NVIDIA --size 1920x1080 --frames 16 --latency-size 1280x720 --latency-frames 16
} > "$OUT/node-bench.log" 2>&1
tail -25 "$OUT/node-bench.log"
