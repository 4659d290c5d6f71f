#!/usr/bin/env bash
# "Watch it live": installs missing dependencies, builds, and runs corvid-view,
# which renders the default scene (the procedural room) on 2 virtual GPUs on
# lavapipe and serves the live frames to a browser page. Open the URL it prints
# (http://127.0.0.1:8080/ unless --port says otherwise): drag to orbit, shift-drag
# to pan, wheel to zoom, WASD to move; Ctrl-C stops it. Extra arguments go to
# corvid-view (scripts/view.sh --help lists them):
#   scripts/view.sh --nodes gpu-box:7700        render on a remote corvid-node (scripts/node.sh)
#   scripts/view.sh --codec h264 --size 1280x720
# The page binds 127.0.0.1 only; to watch from another machine, forward the port
# (ssh -L 8080:127.0.0.1:8080 host) or give --host and --token-file (docs/live-view.md).
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
exec build/apps/corvid-view "${gpus[@]}" "$@"
