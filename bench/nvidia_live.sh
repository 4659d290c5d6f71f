#!/usr/bin/env bash
# Issue 25's live-view figures on the NVIDIA device machine, in one device call (about 4 minutes;
# each part has its own time limit, all within 8): bench_live at 1920x1080, H.264 and JPEG, beside
# the raw-planes path,
#   1. through a corvid-node on the GPU behind bench_live's in-process relay (10 ms one way = 20 ms
#      round trip, 100 Mbit/s each way): the goal;
#   2. the same on the local GPU without node or relay: the render-only ceiling;
# then bench_frame_codec at 1080p on the host's CPUs (the encoders alone). Logs to $OUT/live.log,
# the trace of run 1 to $OUT/live-relay.trace.json (ui.perfetto.dev). Built and packed as for
# bench/nvidia_tests.sh (bench/nvidia_pack.sh build-nv; carry .carry and .gl); from the repository root:
#   bash bench/nvidia_live.sh [seconds per run, default 10]
set -u
secs=${1:-10}
. bench/nvidia_env.sh
cd /tmp/corvid/b/bin || exit 1
log="$OUT/live.log"
node_pid=
trap '[ -n "$node_pid" ] && kill "$node_pid" 2>/dev/null' EXIT
{
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
  nproc
  rm -f /tmp/corvid-node.port
  ./corvid-node --listen 127.0.0.1:0 --port-file /tmp/corvid-node.port --adapters NVIDIA \
    --cache-dir /tmp/corvid-node-cache > "$OUT/node.log" 2>&1 &
  node_pid=$!
  for _ in $(seq 100); do [ -s /tmp/corvid-node.port ] && break; sleep 0.1; done
  port=$(cat /tmp/corvid-node.port 2>/dev/null)
  echo "== 1. through corvid-node (port $port) behind the relay: 20 ms round trip, 100 Mbit/s"
  timeout 240 ./bench_live --nodes "127.0.0.1:$port" --relay-delay-ms 10 --relay-rate-mbit 100 \
    --width 1920 --height 1080 --seconds "$secs" --codec both --trace "$OUT/live-relay.trace.json"
  echo "== exit $?"
  kill "$node_pid"; wait "$node_pid" 2>/dev/null; node_pid=
  echo "== 2. the local GPU, no node, no relay (the render-only ceiling)"
  timeout 120 ./bench_live --adapters NVIDIA --gpus 1 --width 1920 --height 1080 --seconds "$secs" --codec both
  echo "== exit $?"
  echo "== 3. bench_frame_codec at 1920x1080 on $(nproc) CPUs"
  timeout 120 ./bench_frame_codec --sizes 1920x1080
  echo "== exit $?"
} > "$log" 2>&1
cat "$log"
tail -5 "$OUT/node.log"
