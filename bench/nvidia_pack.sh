#!/usr/bin/env bash
# Packs a build for the NVIDIA device machine (Ubuntu 24.04, no Debian
# packages): the test, tool (tools/: corvid-relay) and benchmark binaries (stripped), the shared
# libraries they need that Ubuntu lacks (found with ldd, glibc's own left out: libturbojpeg,
# libopenh264, libwebsockets and the like come along),
# and the two assimp test models the trace tests read, into .carry/b.tar.gz.
# bench/nvidia_env.sh unpacks it there. Usage: bench/nvidia_pack.sh [build dir]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-nv}
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/b/bin" "$stage/b/lib" "$stage/b/models" .carry
find "$build/tests" "$build/apps" "$build/bench" "$build/tools" -maxdepth 2 -type f -executable ! -name "*.so" \
  -newer "$build/CMakeCache.txt" -exec cp {} "$stage/b/bin/" \;
rm -f "$stage/b/bin/bench_trace" "$stage/b/bin/bench_bvh"   # Embree peers: too large to carry
strip "$stage/b/bin/"* 2>/dev/null || true
cp tests/apps/*.sh "$stage/b/bin/"
for bin in "$stage/b/bin/"*; do
  { ldd "$bin" 2>/dev/null || true; } | awk '/=> \//{print $3}'
done | sort -u | grep -vE '/(libc|libm|libpthread|libdl|librt|libgcc_s|libvulkan|ld-linux[^/]*)\.so' |
  while read -r lib; do cp -L "$lib" "$stage/b/lib/"; done
strip --strip-unneeded "$stage/b/lib/"* 2>/dev/null || true
cp /usr/share/assimp/models/OBJ/spider.obj "$stage/b/models/"
cp /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb "$stage/b/models/"
tar -C "$stage" -czf .carry/b.tar.gz b
du -h .carry/b.tar.gz
