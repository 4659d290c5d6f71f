#!/usr/bin/env bash
# Issue 9's benchmark: corvid-render's frame time at a size (default 1920x1080,
# 16 frames) on 1, 2 and 4 virtual GPUs of one adapter, through each transfer
# path (staged, host-import, shared), with the bytes moved; then the transfer
# bandwidth of each path (bench_transfer). Prints one table.
#   bench/mgpu_frames.sh BIN_DIR ADAPTER [WxH] [FRAMES]   (BENCH_BIN=dir of bench_transfer if elsewhere)
set -u
bin=$1 adapter=$2 size=${3:-1920x1080} frames=${4:-16}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf '%-12s %5s %12s %10s %14s %12s\n' path gpus ms/frame vs-1-gpu "moved MB" "transfer ms"
one=
for path in staged host-import shared; do
  for gpus in 1 2 4; do
    [ "$gpus" = 1 ] && [ -n "$one" ] && continue
    log=$out/$path-$gpus.txt
    CORVID_TRANSFER_PATH=$path "$bin/corvid-render" --adapters "$adapter" --gpus "$gpus" --size "$size" \
      --frames "$frames" --out "$out/frame" > "$log" 2>&1 || { echo "$path x$gpus failed: $(tail -1 "$log")"; continue; }
    ms=$(sed -n 's/.*; \([0-9.]*\) ms per frame;.*/\1/p' "$log")
    moved=$(sed -n 's/transfers between devices: \([0-9.]*\) MB in \([0-9.]*\) ms.*/\1 \2/p' "$log")
    [ "$gpus" = 1 ] && one=$ms
    ratio=$(awk -v a="$ms" -v b="$one" 'BEGIN { if (b > 0) printf "%.2fx", a / b; else print "-" }')
    printf '%-12s %5s %12s %10s %14s %12s\n' "$path" "$gpus" "$ms" "$ratio" ${moved:-"- -"}
  done
done
echo
echo "== bench_transfer (every path side by side, memcpy as the peer)"
"${BENCH_BIN:-$bin}/bench_transfer" --adapters "$adapter" --sizes 1M,16M,256M --only vulkan 2>&1 | tail -14
