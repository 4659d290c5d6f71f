#!/usr/bin/env python3
"""Writes a glTF scene of alpha-masked foliage for measuring the alpha-mask
rule's cost (docs/renderer-quality.md, "Alpha-masked secondary rays"): a
floor, a back wall and a 6 x 6 grid of tilted "leaf" quads at two heights,
whose base color image has round holes (alpha 0 in about 28% of it), under
the glTF's default light (corvid-render's sun). With --opaque the leaves are
alphaMode OPAQUE (the same geometry without the rule: no re-trace runs).

Usage: python3 bench/alpha_scene.py OUT_DIR [--opaque]
       build/apps/corvid-render --scene OUT_DIR/leaves.gltf --stats stats.json ...
"""
import base64
import json
import math
import os
import struct
import sys
import zlib


def png_rgba(width, height, texel):
    rows = b"".join(b"\x00" + b"".join(bytes(texel(x, y)) for x in range(width)) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def holes(x, y):
    cx = ((x + 0.5) / 32.0 * 2.0) % 1.0 - 0.5
    cy = ((y + 0.5) / 32.0 * 2.0) % 1.0 - 0.5
    return (60, 150, 50, 0 if cx * cx + cy * cy < 0.09 else 255)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out, opaque = sys.argv[1], "--opaque" in sys.argv[2:]
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "holes.png"), "wb") as f:
        f.write(png_rgba(32, 32, holes))
    # Quads: (corner, edge a, edge b, material); two triangles each, flat normal a x b.
    quads = [((-4, 0, 4), (8, 0, 0), (0, 0, -8), 0), ((-4, 0, -4), (8, 0, 0), (0, 4, 0), 0)]
    for i in range(6):
        for j in range(6):
            x, z, y = -3 + i * 1.1, -3 + j * 1.1, 1.2 + 0.5 * ((i + j) % 2)
            tilt = 0.3 + 0.1 * ((i * 7 + j * 3) % 5)
            quads.append(((x, y, z), (0.9, 0, 0), (0, 0.9 * math.sin(tilt), -0.9 * math.cos(tilt)), 1))
    positions, normals, uvs, indices = [], [], [], []
    meshes, nodes = [], []
    data = b""
    views, accessors = [], []

    def add_view(blob, target):
        nonlocal data
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob), "target": target})
        data += blob + b"\x00" * (-len(blob) % 4)
        return len(views) - 1

    for corner, a, b, material in quads:
        n = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        ln = math.sqrt(sum(c * c for c in n))
        n = tuple(c / ln for c in n)
        p = [corner, tuple(corner[k] + a[k] for k in range(3)), tuple(corner[k] + a[k] + b[k] for k in range(3)),
             tuple(corner[k] + b[k] for k in range(3))]
        pos = struct.pack("<12f", *[c for v in p for c in v])
        nor = struct.pack("<12f", *(n * 4))
        uv = struct.pack("<8f", 0, 0, 1, 0, 1, 1, 0, 1)
        idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3)
        base = len(accessors)
        lo = [min(v[k] for v in p) for k in range(3)]
        hi = [max(v[k] for v in p) for k in range(3)]
        accessors += [
            {"bufferView": add_view(pos, 34962), "componentType": 5126, "count": 4, "type": "VEC3", "min": lo,
             "max": hi},
            {"bufferView": add_view(nor, 34962), "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": add_view(uv, 34962), "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": add_view(idx, 34963), "componentType": 5123, "count": 6, "type": "SCALAR"},
        ]
        meshes.append({"primitives": [{"attributes": {"POSITION": base, "NORMAL": base + 1, "TEXCOORD_0": base + 2},
                                       "indices": base + 3, "material": material}]})
        nodes.append({"mesh": len(meshes) - 1})
    leaf = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0,
                                     "roughnessFactor": 0.8}, "doubleSided": True}
    leaf["alphaMode"] = "OPAQUE" if opaque else "MASK"
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0,
                                                "roughnessFactor": 0.6}}, leaf],
        "textures": [{"source": 0}],
        "images": [{"uri": "holes.png"}],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    with open(os.path.join(out, "leaves.gltf"), "w") as f:
        json.dump(gltf, f)


if __name__ == "__main__":
    main()
