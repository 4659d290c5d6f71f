#!/usr/bin/env bash
# The README's main job: installs missing dependencies, builds, and renders the
# default scene (the procedural room) on 2 virtual GPUs on lavapipe, writing
# out/frame.exr and out/frame.png. Extra arguments go to corvid-render
# (scripts/render.sh --help lists them); `scripts/render.sh --nodes host:port`
# renders on a remote corvid-node instead (scripts/node.sh starts one).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-deps.sh
bash scripts/build.sh
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
# Local devices unless the user chose devices: --gpus/--adapters, or remote
# nodes (--nodes, CORVID_NODES), which serve the devices they were started with.
gpus=(--gpus 2 --adapters llvmpipe)
[ -n "${CORVID_NODES:-}" ] && gpus=()
for arg in "$@"; do
  case "$arg" in
    --gpus|--gpus=*|--virtual-gpus|--virtual-gpus=*|--adapters|--adapters=*|--nodes|--nodes=*) gpus=() ;;
  esac
done
exec build/apps/corvid-render "${gpus[@]}" "$@"
