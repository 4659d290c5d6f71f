#!/usr/bin/env bash
# Issue 9's benchmark: corvid-render's frame time at a size (default 1920x1080,
# 16 frames) on 1, 2 and 4 virtual GPUs of one adapter, through each transfer
# path (staged, host-import, shared), with the bytes moved. Each multi-GPU case
# runs twice in the same run: as shipped (frames pipelined, transfers queued on
# the GPUs through rings where the path allows: "async") and with
# CORVID_TRANSFER_ASYNC=0 (every transfer synchronous on the host: "sync", the
# peer). Then the transfer bandwidth of each path (bench_transfer) and ring
# transfers against synchronous ones (bench_transfer_async). Then the
# cross-device wait of the rings compared: the shared path on 2 and 4 virtual
# GPUs with CORVID_CROSS_WAIT=bridge (a host thread per device) and =import
# (the other device's semaphore imported; refused where the devices lack
# VK_KHR_external_semaphore_fd, e.g. lavapipe: shown as "-"). Then the
# virtual GPUs on one VkDevice (CORVID_VGPU_DEVICE=shared: their queues may run
# concurrently, separate VkDevices are time-sliced) on 2 and 4 virtual GPUs,
# path auto (which takes the direct "device" path there), async and sync,
# against the same with separate VkDevices. Then the queue the link copies run
# on (CORVID_LINK_QUEUE=compute, the default, against graphics and the copy
# family) on one VkDevice, paths device and shared, 2 and 4 virtual GPUs.
# Then zero-copy gathers (CORVID_ZERO_COPY=on: the secondaries trace into the
# primary's memory, the gathers are GPU-side waits) against the same frames
# with copies (=off, path auto), on one VkDevice and on separate ones.
# Prints tables.
#   bench/mgpu_frames.sh BIN_DIR ADAPTER [WxH] [FRAMES]   (BENCH_BIN=dir of the benches if elsewhere)
#   MGPU_MODE=cross-wait bench/mgpu_frames.sh ...   only the one-device run and the cross-wait table
#   MGPU_MODE=vgpu bench/mgpu_frames.sh ...         only the one-device run and the shared-VkDevice table
#   MGPU_MODE=link-queue bench/mgpu_frames.sh ...   only the one-device run and the link-queue table
#   MGPU_MODE=zero-copy bench/mgpu_frames.sh ...    only the one-device run and the zero-copy table
set -u
bin=$1 adapter=$2 size=${3:-1920x1080} frames=${4:-16}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
mode=${MGPU_MODE:-all}
# run PATH GPUS ASYNC [CROSS_WAIT] [VGPU_DEVICE] [LINK_QUEUE] [ZERO_COPY]
#   -> "ms moved_MB transfer_ms" or nothing on failure
run() {
  local log=$out/$1-$2-$3-${4:-auto}-${5:-separate}-${6:-compute}-${7:-off}.txt
  CORVID_ZERO_COPY=${7:-off} CORVID_LINK_QUEUE=${6:-compute} CORVID_VGPU_DEVICE=${5:-separate} CORVID_CROSS_WAIT=${4:-auto} \
    CORVID_TRANSFER_PATH=$1 CORVID_TRANSFER_ASYNC=$3 \
    "$bin/corvid-render" --adapters "$adapter" --gpus "$2" \
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
cross_wait_table() {
  echo
  echo "== cross-device waits of the rings: shared path, CORVID_CROSS_WAIT=bridge vs import (same run)"
  printf '%-12s %5s %12s %9s %12s %9s %9s  %s\n' path gpus "bridge ms/f" vs-1-gpu "import ms/f" vs-1-gpu imp/brg \
    "in use (gpu1, bridge / import run)"
  for gpus in 2 4; do
    read -r b_ms _ _ <<< "$(run shared "$gpus" 1 bridge)"
    read -r i_ms _ _ <<< "$(run shared "$gpus" 1 import)"
    # What corvid-render's device lines say each run used.
    local b_use i_use
    b_use=$(sed -n 's/^gpu1: .*cross-device waits: \([a-z-]*\).*/\1/p' "$out/shared-$gpus-1-bridge-separate-compute-off.txt" | head -1)
    i_use=$(sed -n 's/^gpu1: .*cross-device waits: \([a-z-]*\).*/\1/p' "$out/shared-$gpus-1-import-separate-compute-off.txt" | head -1)
    printf '%-12s %5s %12s %9s %12s %9s %9s  %s\n' shared "$gpus" "${b_ms:--}" "$(ratio "${b_ms:-0}" "${one:-0}")" \
      "${i_ms:--}" "$(ratio "${i_ms:-0}" "${one:-0}")" "$(ratio "${i_ms:-0}" "${b_ms:-0}")" "${b_use:--} / ${i_use:--}"
  done
}
vgpu_table() {
  echo
  echo "== virtual GPUs on one VkDevice (CORVID_VGPU_DEVICE=shared) vs one VkDevice each (separate), path auto (same run)"
  printf '%-12s %5s %12s %9s %12s %9s %12s %9s %10s\n' mode gpus "async ms/f" vs-1-gpu "sync ms/f" vs-1-gpu \
    "separate" vs-1-gpu "moved MB"
  read -r one_shared _ _ <<< "$(run auto 1 1 auto shared)"
  printf '%-12s %5s %12s %9s %12s %9s %12s %9s %10s\n' shared 1 "${one_shared:--}" \
    "$(ratio "${one_shared:-0}" "${one:-0}")" "-" "-" "${one:--}" 1.00x 0
  for gpus in 2 4; do
    read -r a_ms a_mb _ <<< "$(run auto "$gpus" 1 auto shared)"
    read -r s_ms _ _ <<< "$(run auto "$gpus" 0 auto shared)"
    read -r p_ms _ _ <<< "$(run auto "$gpus" 1 auto separate)"
    printf '%-12s %5s %12s %9s %12s %9s %12s %9s %10s\n' shared "$gpus" "${a_ms:--}" "$(ratio "${a_ms:-0}" "${one:-0}")" \
      "${s_ms:--}" "$(ratio "${s_ms:-0}" "${one:-0}")" "${p_ms:--}" "$(ratio "${p_ms:-0}" "${one:-0}")" "${a_mb:--}"
  done
}
link_queue_table() {
  echo
  echo "== the queue of the link copies (CORVID_LINK_QUEUE), one VkDevice (CORVID_VGPU_DEVICE=shared), async (same run)"
  printf '%-12s %5s %12s %9s %12s %9s %12s %9s\n' path gpus "compute ms/f" vs-1-gpu "graphics" vs-1-gpu "copy" vs-1-gpu
  for path in device shared; do
    for gpus in 2 4; do
      read -r c_ms _ _ <<< "$(run "$path" "$gpus" 1 auto shared compute)"
      read -r g_ms _ _ <<< "$(run "$path" "$gpus" 1 auto shared graphics)"
      read -r x_ms _ _ <<< "$(run "$path" "$gpus" 1 auto shared copy)"
      printf '%-12s %5s %12s %9s %12s %9s %12s %9s\n' "$path" "$gpus" "${c_ms:--}" "$(ratio "${c_ms:-0}" "${one:-0}")" \
        "${g_ms:--}" "$(ratio "${g_ms:-0}" "${one:-0}")" "${x_ms:--}" "$(ratio "${x_ms:-0}" "${one:-0}")"
    done
  done
}
zero_copy_table() {
  echo
  echo "== zero-copy gathers (CORVID_ZERO_COPY=on) vs copies (=off), path auto, async (same run)"
  printf '%-12s %5s %12s %9s %10s %12s %9s %10s\n' vkdevice gpus "zero-copy" vs-1-gpu "moved MB" "copies" vs-1-gpu \
    "moved MB"
  for vgpu in shared separate; do
    for gpus in 2 4; do
      read -r z_ms z_mb _ <<< "$(run auto "$gpus" 1 auto "$vgpu" compute on)"
      read -r c_ms c_mb _ <<< "$(run auto "$gpus" 1 auto "$vgpu" compute off)"
      printf '%-12s %5s %12s %9s %10s %12s %9s %10s\n' "$vgpu" "$gpus" "${z_ms:--}" "$(ratio "${z_ms:-0}" "${one:-0}")" \
        "${z_mb:--}" "${c_ms:--}" "$(ratio "${c_ms:-0}" "${one:-0}")" "${c_mb:--}"
    done
  done
}
if [ "$mode" = zero-copy ]; then
  zero_copy_table
  exit 0
fi
if [ "$mode" = link-queue ]; then
  link_queue_table
  exit 0
fi
if [ "$mode" = cross-wait ]; then
  cross_wait_table
  exit 0
fi
if [ "$mode" = vgpu ]; then
  vgpu_table
  exit 0
fi
for path in staged host-import shared; do
  for gpus in 2 4; do
    read -r a_ms a_mb _ <<< "$(run "$path" "$gpus" 1)"
    read -r s_ms _ _ <<< "$(run "$path" "$gpus" 0)"
    printf '%-12s %5s %12s %9s %12s %9s %10s\n' "$path" "$gpus" "${a_ms:--}" "$(ratio "${a_ms:-0}" "${one:-0}")" \
      "${s_ms:--}" "$(ratio "${s_ms:-0}" "${one:-0}")" "${a_mb:--}"
  done
done
cross_wait_table
vgpu_table
link_queue_table
zero_copy_table
echo
echo "== bench_transfer_async (ring transfers vs synchronous ones, same bytes, same run)"
for cw in bridge import; do
  echo "-- CORVID_CROSS_WAIT=$cw"
  CORVID_CROSS_WAIT=$cw "${BENCH_BIN:-$bin}/bench_transfer_async" --adapters "$adapter" --sizes 1M,8M,64M 2>&1 | tail -8
done
echo
echo "== bench_transfer (every path side by side, memcpy as the peer)"
"${BENCH_BIN:-$bin}/bench_transfer" --adapters "$adapter" --sizes 1M,16M,256M --only vulkan 2>&1 | tail -14
