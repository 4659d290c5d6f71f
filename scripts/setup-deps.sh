#!/usr/bin/env bash
# Installs the Debian 12 packages Corvid needs, skipping what is already present.
# Vulkan on CPU machines is Mesa 25 lavapipe from bookworm-backports (Vulkan 1.4,
# descriptor indexing, ray-tracing pipeline), see docs/building.md. clang and
# clang-format (14) are for CI's clang build and format check.
# Idempotent: a second run with everything installed touches nothing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config clang clang-format
  libvulkan-dev vulkan-validationlayers glslang-tools spirv-tools vulkan-tools
  libgrpc-dev libprotobuf-c-dev protobuf-c-compiler libmicrohttpd-dev
  libopenexr-dev libpng-dev libjpeg-dev libzstd-dev libssl-dev openssl
  libassimp-dev assimp-testmodels libembree-dev libcjson-dev
  libturbojpeg0-dev libopenh264-dev libwebsockets-dev   # live view: JPEG, H.264, HTTP + WebSocket
  chromium chromium-driver   # tests/web: the viewer page in a real (headless) browser
  python3-yaml   # tests/apps/deploy_test.sh parses deploy/*.yaml
  python3-grpcio python3-grpc-tools   # tests/apps/proto_python_test.sh: a Python client from proto/ alone
)
backports_packages=(mesa-vulkan-drivers)
min_mesa_major=25

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup-deps: need root or sudo to install packages" >&2; exit 1; }
  sudo_cmd=(sudo)
fi

is_installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

mesa_major() {
  dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | sed -E 's/^([0-9]+:)?([0-9]+).*/\2/'
}

missing=()
for p in "${packages[@]}"; do is_installed "$p" || missing+=("$p"); done
need_mesa=0
if ! is_installed mesa-vulkan-drivers || [ "$(mesa_major)" -lt "$min_mesa_major" ]; then need_mesa=1; fi

if [ ${#missing[@]} -eq 0 ] && [ $need_mesa -eq 0 ]; then
  echo "setup-deps: all dependencies present"
  exit 0
fi

export DEBIAN_FRONTEND=noninteractive
if [ $need_mesa -eq 1 ] && ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
  echo "setup-deps: adding bookworm-backports (for Mesa 25 lavapipe)"
  if [ -f /etc/apt/sources.list.d/debian.sources ]; then
    uris=$(awk '/^URIs:/ && /debian\/?$/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
    keyring=$(awk '/^Signed-By:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
  fi
  uris=${uris:-http://deb.debian.org/debian}
  keyring=${keyring:-/usr/share/keyrings/debian-archive-keyring.gpg}
  printf 'Types: deb\nURIs: %s\nSuites: bookworm-backports\nComponents: main\nSigned-By: %s\n' \
    "$uris" "$keyring" | "${sudo_cmd[@]}" tee /etc/apt/sources.list.d/corvid-backports.sources >/dev/null
fi

echo "setup-deps: installing ${missing[*]} ${need_mesa:+(mesa from backports)}"
"${sudo_cmd[@]}" apt-get update -q
if [ ${#missing[@]} -gt 0 ]; then
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
if [ $need_mesa -eq 1 ]; then
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends -t bookworm-backports "${backports_packages[@]}"
fi
echo "setup-deps: done (mesa-vulkan-drivers $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers))"
