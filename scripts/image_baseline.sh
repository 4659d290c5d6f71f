#!/usr/bin/env bash
# The renderer's, node's and cluster's images as SHA-256 sums of their EXR files, for checking
# that a refactor changes no pixel (issue 24: "same EXR bytes on lavapipe").
#   scripts/image_baseline.sh BUILD_DIR OUT_DIR    renders the set, prints "sum  name" lines
# Compare two runs with diff. Small images, so the whole set takes about a minute on 2 cores.
set -euo pipefail
build=${1:?usage: image_baseline.sh BUILD_DIR OUT_DIR}
out=${2:?usage: image_baseline.sh BUILD_DIR OUT_DIR}
render=$build/apps/corvid-render
node=$build/apps/corvid-node
mkdir -p "$out"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
base=(--size 160x96 --frames 3 --quiet)
run() {
  local name=$1
  shift
  "$@" --out "$out/$name" >"$out/$name.log" 2>&1 || { echo "FAILED: $name (log: $out/$name.log)" >&2; cat "$out/$name.log" >&2; exit 1; }
}
run room1 "$render" "${base[@]}" --gpus 1
run room2 "$render" "${base[@]}" --gpus 2
run room3_orbit "$render" "${base[@]}" --gpus 3 --orbit 5 --frames 4 --reflection-scale 0.5
CORVID_ZERO_COPY=off CORVID_TRANSFER_PATH=staged CORVID_TRANSFER_ASYNC=0 \
  run room2_staged "$render" "${base[@]}" --gpus 2
run stress "$render" "${base[@]}" --gpus 2 --scene stress:3000 --shadow-samples 4 --ao-samples 2 --filter 0
run room_noreflect "$render" "${base[@]}" --gpus 2 --reflections off --filter 3 --sun 0.3,1,0.2,4
run room_samples "$render" "${base[@]}" --gpus 2 --reflection-samples 2 --reflect-radius 2 --seed 7
run reference "$render" --size 64x40 --reference 2 --quiet
# one node serving 2 virtual GPUs, and a cluster of two nodes
port1=$((20000 + RANDOM % 20000)) port2=$((port1 + 1))
"$node" --listen 127.0.0.1:$port1 --gpus 2 --cache-dir "$out/cache1" >"$out/node1.log" 2>&1 &
pid1=$!
"$node" --listen 127.0.0.1:$port2 --gpus 1 --cache-dir "$out/cache2" >"$out/node2.log" 2>&1 &
pid2=$!
trap 'kill $pid1 $pid2 2>/dev/null || true; wait 2>/dev/null || true' EXIT
for i in $(seq 50); do grep -q listening "$out/node1.log" && grep -q listening "$out/node2.log" && break; sleep 0.2; done
run node "$render" "${base[@]}" --nodes 127.0.0.1:$port1
run cluster "$render" "${base[@]}" --nodes 127.0.0.1:$port1,127.0.0.1:$port2
(cd "$out" && sha256sum ./*.exr | sed 's| \./| |')
