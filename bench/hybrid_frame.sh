#!/usr/bin/env bash
# Issue 11's hybrid-frame benchmark: corvid-render's frame (G-buffer, 1 shadow
# ray and N AO rays per pixel, GGX reflections at full or half resolution,
# accumulate, filters, composite) at a size, on one device. Two runs of the
# same frames: as shipped (frames pipelined: the frame time a user gets) and
# with --stats (each frame waits so that its GPU pass times are read: the
# per-pass figures). Prints both and the mean GPU ms of every pass per frame
# (python3 reads the stats JSON; without it the JSON is left in OUT_DIR).
# REFLECTION_SAMPLES (default 1) is --reflection-samples; OUT_DIR may be "" to
# keep nothing.
#   bench/hybrid_frame.sh BIN_DIR ADAPTER [WxH] [FRAMES] [AO] [REFLECTION_SCALE] [OUT_DIR] [REFLECTION_SAMPLES]
set -u
bin=$1 adapter=$2 size=${3:-1920x1080} frames=${4:-64} ao=${5:-1} scale=${6:-0.5} keep=${7:-} rs=${8:-1}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
common=(--adapters "$adapter" --gpus 1 --size "$size" --frames "$frames" --ao-samples "$ao" --reflection-scale "$scale")
[ "$rs" != 1 ] && common+=(--reflection-samples "$rs")
echo "corvid-render $size, $frames frames, $ao AO ray(s)/pixel, reflections at scale $scale x $rs sample(s), adapter $adapter"
"$bin/corvid-render" "${common[@]}" --out "$out/pipelined" 2>&1 | grep -E "ms per frame" || echo "pipelined run failed"
"$bin/corvid-render" "${common[@]}" --out "$out/timed" --stats "$out/stats.json" 2>&1 | grep -E "ms per frame" ||
  echo "timed run failed"
[ -n "$keep" ] && cp "$out/stats.json" "$keep/hybrid-stats.json" 2>/dev/null
command -v python3 >/dev/null || exit 0
python3 - "$out/stats.json" "$frames" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
frames = d["summary"]["frames"]
rows = d["summary"]["passes"]
total = 0.0
print("pass            instances   GPU ms per frame")
for p in rows:
    per = p["ms_total"] / frames
    total += per if not p["name"].startswith("transfer") else 0.0
    print("%-16s %9d %12.3f" % (p["name"], p["instances"], per))
print("%-16s %9s %12.3f" % ("sum of passes", "", total))
walls = [f["wall_ms"] for f in d["frames"]]
walls.sort()
print("frame wall ms (each frame waited): median %.3f" % walls[len(walls) // 2])
PY
