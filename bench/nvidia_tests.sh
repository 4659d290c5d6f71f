# Runs the Vulkan test binaries, the conformance suite (local and through an
# in-process corvid-node), the node tests and the renderer test on
# the NVIDIA machine (validation layer on), logging to $OUT/tests.log.
. bench/nvidia_env.sh
cd /tmp/corvid/b/bin
{
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
  corvid-render --list-adapters
  pass=0; fail=0
  for t in vk_* "conformance vulkan" renderer_frames renderer_transfer_paths renderer_temporal renderer_reflect \
           render_outputs render_log renderer_texture renderer_alpha renderer_step live live_link test_media_codec node_encode_hostile trace_paths node_hostile node_peer_hostile node_isolation vk_device_churn "conformance proxy-vulkan" node_remote_render proxy_dead_session \
           "node_cluster /tmp/corvid/b/bin/corvid-node"; do
    echo "== $t"
    unset CORVID_VIRTUAL_GPUS
    [ "$t" = vk_virtual_gpu ] && export CORVID_VIRTUAL_GPUS=3
    if timeout 150 ./$t; then pass=$((pass+1)); else fail=$((fail+1)); fi
  done
  echo "binaries: $pass passed, $fail failed"
} > "$OUT/tests.log" 2>&1
grep -E "passed|failed|==|NVIDIA" "$OUT/tests.log" | tail -40
