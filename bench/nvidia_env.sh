# Sourced at the start of a command on the NVIDIA device machine (see
# docs/nvidia.md): unpacks the carried Vulkan loader, glvnd and validation
# layer packages, points the loader at NVIDIA's ICD and unpacks the carried
# build (binaries and the shared libraries Debian has and Ubuntu lacks).
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
export XDG_RUNTIME_DIR=/tmp CORVID_TEST_ADAPTER=NVIDIA
mkdir -p /tmp/corvid && tar -C /tmp/corvid -xzf .carry/b.tar.gz
export LD_LIBRARY_PATH=/tmp/corvid/b/lib
export PATH=/tmp/corvid/b/bin:$PATH
# The assimp test models the trace test and benchmark read (Debian's assimp-testmodels paths).
mkdir -p /usr/share/assimp/models/OBJ /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary
cp /tmp/corvid/b/models/spider.obj /usr/share/assimp/models/OBJ/
cp /tmp/corvid/b/models/2CylinderEngine.glb /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/
