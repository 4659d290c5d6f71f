#!/usr/bin/env bash
# Installs missing dependencies, builds, and runs corvid-node, the render-proxy
# server, in the foreground. Arguments go to corvid-node (scripts/node.sh --help);
# without --listen it listens on 127.0.0.1:7700, so only this machine can reach it.
#   scripts/node.sh --listen 0.0.0.0:7700 --token-file ~/.corvid-token --adapters H100 --gpus 2
# (a node on anything but loopback needs --token-file; see docs/node.md, "Security")
# SIGTERM or Ctrl-C drains it (running sessions finish) and it exits 0.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-deps.sh
bash scripts/build.sh
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
exec build/apps/corvid-node "$@"
