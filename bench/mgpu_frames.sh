#!/usr/bin/env bash
# Issue 9's benchmark: corvid-render's frame time at a size (default 1920x1080,
# 16 frames) on 1, 2 and 4 virtual GPUs of one adapter, through each transfer
# path (staged, host-import, shared), with the bytes moved. Each multi-GPU case
# runs twice in the same run: as shipped (frames pipelined, transfers queued on
# the GPUs through rings where the path allows: "async") and with
# CORVID_TRANSFER_ASYNC=0 (every transfer synchronous on the host: "sync", the
# peer). Then the transfer bandwidth of each path (bench_transfer) and ring
# transfers against synchronous ones (bench_transfer_async). Prints tables.
#   bench/mgpu_frames.sh BIN_DIR ADAPTER [WxH] [FRAMES]   (BENCH_BIN=dir of the benches if elsewhere)
set -u
bin=$1 adapter=$2 size=${3:-1920x1080} frames=${4:-16}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# run PATH GPUS ASYNC -> "ms moved_MB transfer_ms" or nothing on failure
run() {
  local log=$out/$1-$2-$3.txt
  CORVID_TRANSFER_PATH=$1 CORVID_TRANSFER_ASYNC=$3 "$bin/corvid-render" --adapters "$adapter" --gpus "$2" \
    --size "$size" --frames "$frames" --out "$out/frame" > "$log" 2>&1 || { echo "$1 x$2 failed: $(tail -1 "$log")" >&2; return; }
  local ms moved
  ms=$(sed -n 's/.*; \([0-9.]*\) ms per frame;.*/\1/p' "$log")
  moved=$(sed -n 's/transfers between devices: \([0-9.]*\) MB in \([0-9.]*\) ms.*/\1 \2/p' "$log")
  echo "$ms ${moved:-- -}"
}
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (a > 0 && b > 0) printf "%.2fx", a / b; else print "-" }'; }
echo "corvid-render $size, $frames frames, adapter $adapter"
printf '%-12s %5s %12s %9s %12s %9s %10s\n' path gpus "async ms/f" vs-1-gpu "sync ms/f" vs-1-gpu "moved MB"
read -r one _ _ <<< "$(run shared 1 1)"
printf '%-12s %5s %12s %9s %12s %9s %10s\n' "-" 1 "${one:--}" 1.00x "-" "-" 0
for path in staged host-import shared; do
  for gpus in 2 4; do
    read -r a_ms a_mb _ <<< "$(run "$path" "$gpus" 1)"
    read -r s_ms _ _ <<< "$(run "$path" "$gpus" 0)"
    printf '%-12s %5s %12s %9s %12s %9s %10s\n' "$path" "$gpus" "${a_ms:--}" "$(ratio "${a_ms:-0}" "${one:-0}")" \
      "${s_ms:--}" "$(ratio "${s_ms:-0}" "${one:-0}")" "${a_mb:--}"
  done
done
echo
echo "== bench_transfer_async (ring transfers vs synchronous ones, same bytes, same run)"
"${BENCH_BIN:-$bin}/bench_transfer_async" --adapters "$adapter" --sizes 1M,8M,64M 2>&1 | tail -8
echo
echo "== bench_transfer (every path side by side, memcpy as the peer)"
"${BENCH_BIN:-$bin}/bench_transfer" --adapters "$adapter" --sizes 1M,16M,256M --only vulkan 2>&1 | tail -14
