#!/usr/bin/env python3
"""make_source.py: writes source.glb, the small uncompressed scene the compressed test files are
made from (README.md beside this file): a UV sphere (radius 0.5, 16 x 10, 288 triangles) standing
on a 2 x 2 m ground plane (8 x 8 quads, 128 triangles), both with normals and 32-bit float
positions, each under its own node (the sphere's node translated by (0.2, 0.5, -0.1)), and one
perspective camera. Deterministic: the same bytes every run (Python 3, standard library only)."""
import json, math, struct, sys

def sphere(r, nseg, nring):
    pos, nrm, idx = [], [], []
    for j in range(nring + 1):
        th = math.pi * j / nring
        for i in range(nseg + 1):
            ph = 2 * math.pi * i / nseg
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            nrm.append(n)
            pos.append(tuple(r * c for c in n))
    for j in range(nring):
        for i in range(nseg):
            a = j * (nseg + 1) + i
            b = a + nseg + 1
            if j != 0:
                idx += [a, a + 1, b]
            if j != nring - 1:
                idx += [a + 1, b + 1, b]
    return pos, nrm, idx

def plane(half, n):
    pos, nrm, idx = [], [], []
    for j in range(n + 1):
        for i in range(n + 1):
            pos.append((-half + 2 * half * i / n, 0.0, -half + 2 * half * j / n))
            nrm.append((0.0, 1.0, 0.0))
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b = a + n + 1
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, nrm, idx

bin_ = bytearray()
views, accessors, meshes = [], [], []

def add_view(data, target):
    while len(bin_) % 4:
        bin_.append(0)
    views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data), "target": target})
    bin_.extend(data)
    return len(views) - 1

def add_mesh(name, pos, nrm, idx):
    f32 = lambda v: struct.pack("<%df" % (3 * len(v)), *[c for p in v for c in p])
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    lo = [struct.unpack("<f", struct.pack("<f", x))[0] for x in lo]
    hi = [struct.unpack("<f", struct.pack("<f", x))[0] for x in hi]
    a0 = len(accessors)
    accessors.append({"bufferView": add_view(f32(pos), 34962), "componentType": 5126, "count": len(pos),
                      "type": "VEC3", "min": lo, "max": hi})
    accessors.append({"bufferView": add_view(f32(nrm), 34962), "componentType": 5126, "count": len(nrm),
                      "type": "VEC3"})
    accessors.append({"bufferView": add_view(struct.pack("<%dH" % len(idx), *idx), 34963), "componentType": 5123,
                      "count": len(idx), "type": "SCALAR"})
    meshes.append({"name": name, "primitives": [{"attributes": {"POSITION": a0, "NORMAL": a0 + 1},
                                                  "indices": a0 + 2, "material": 0}]})
    return len(meshes) - 1

g = add_mesh("ground", *plane(1.0, 8))
s = add_mesh("sphere", *sphere(0.5, 16, 10))
while len(bin_) % 4:
    bin_.append(0)
pitch = math.atan2(0.8, 2.2)  # the camera at (0, 1.2, 2.2) looks down at (0, 0.4, 0)
doc = {
    "asset": {"version": "2.0", "generator": "obscura tests/data/gltf/make_source.py"},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [{"name": "ground", "mesh": g},
              {"name": "sphere", "mesh": s, "translation": [0.2, 0.5, -0.1]},
              {"name": "default", "camera": 0, "translation": [0.0, 1.2, 2.2],
               "rotation": [-math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 20.0}}],
    "materials": [{"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}}],
    "meshes": meshes, "accessors": accessors, "bufferViews": views,
    "buffers": [{"byteLength": len(bin_)}],
}
js = json.dumps(doc, separators=(",", ":"), sort_keys=True).encode()
js += b" " * ((4 - len(js) % 4) % 4)
out = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(bin_))
out += struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(bin_), b"BIN\0") + bytes(bin_)
open(sys.argv[1] if len(sys.argv) > 1 else "source.glb", "wb").write(out)
