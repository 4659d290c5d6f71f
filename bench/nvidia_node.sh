#!/usr/bin/env bash
# On the NVIDIA device machine: the tests (bench/nvidia_tests.sh), then
# bench_node on the GPU (local render vs the same render through a corvid-node
# on loopback, result stream, uploads, latency through a delaying relay),
# logging to $OUT/node-bench.log; then issue 9's multi-GPU frame times per
# transfer path (bench/mgpu_frames.sh), logging to $OUT/mgpu.log; then issue
# 11's hybrid frame and its passes (bench/hybrid_frame.sh), to $OUT/hybrid.log.
repo=$(pwd)
bash bench/nvidia_tests.sh
. bench/nvidia_env.sh
cd /tmp/corvid/b/bin
{ nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
  timeout 300 ./bench_node --adapter NVIDIA --size 1920x1080 --frames 16 --latency-size 1280x720 --latency-frames 16
} > "$OUT/node-bench.log" 2>&1
tail -25 "$OUT/node-bench.log"
{ echo "== issue 9: frame time on 1, 2, 4 virtual GPUs of the H200 per transfer path, 1920x1080, 16 frames"
  bash "$repo/bench/mgpu_frames.sh" . NVIDIA 1920x1080 16
} > "$OUT/mgpu.log" 2>&1
cat "$OUT/mgpu.log"
{ echo "== issue 11: the hybrid frame at 1920x1080 on one H200 (1 shadow + 1 AO ray, half-resolution reflections)"
  bash "$repo/bench/hybrid_frame.sh" . NVIDIA 1920x1080 64 1 0.5 "$OUT"
  echo "== the same with full-resolution reflections"
  bash "$repo/bench/hybrid_frame.sh" . NVIDIA 1920x1080 64 1 1
} > "$OUT/hybrid.log" 2>&1
cat "$OUT/hybrid.log"
