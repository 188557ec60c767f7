"""Writes cards.gltf: 60 leaf cards, one alpha-masked double-sided material, and its RGBA leaf
texture with a cut-out outline embedded as a data URI (the repository ignores *.png), for
scenes/extra/leaf-cards.toml. Deterministic (seed 7).

Run from this folder: python3 make.py   (needs numpy and Pillow)"""
import base64, io, json
import numpy as np
from PIL import Image

N = 128
y, x = np.mgrid[0:N, 0:N]
u, v = (x + 0.5) / N, (y + 0.5) / N
# A leaf along v: half-width 0.42 sin(pi v)^0.8 around u = 0.5, and a stem gap down the middle.
half = 0.42 * np.sin(np.pi * v) ** 0.8
inside = (np.abs(u - 0.5) < half) & ~((np.abs(u - 0.5) < 0.012) & (v > 0.15))
green = np.stack([0.18 + 0.1 * v, 0.45 + 0.2 * (1 - v), 0.12 + 0 * v], -1)
rgba = np.concatenate([green, inside[..., None].astype(float)], -1)
png = io.BytesIO()
Image.fromarray((rgba * 255).round().astype(np.uint8), "RGBA").save(png, format="PNG")

rng = np.random.default_rng(7)
positions, uvs, indices = [], [], []
for k in range(60):
    c = np.array([rng.uniform(-0.7, 0.7), rng.uniform(0.25, 1.35), rng.uniform(-0.7, 0.7)])
    # A random frame: the card's plane spanned by a and b.
    a = rng.normal(size=3); a /= np.linalg.norm(a)
    b = np.cross(a, rng.normal(size=3)); b /= np.linalg.norm(b)
    s = 0.16
    corners = [c - s * a - s * b, c + s * a - s * b, c + s * a + s * b, c - s * a + s * b]
    base = len(positions)
    positions += corners
    uvs += [(0, 1), (1, 1), (1, 0), (0, 0)]
    indices += [(base, base + 1, base + 2), (base, base + 2, base + 3)]

pos = np.array(positions, np.float32)
buf = pos.tobytes() + np.array(uvs, np.float32).tobytes() + np.array(indices, np.uint32).tobytes()
n = len(positions)
gltf = {
    "asset": {"version": "2.0", "generator": "glimpse scenes/extra/leaf-cards/make.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"name": "cards", "mesh": 0}],
    "meshes": [{"name": "cards", "primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
    "materials": [{
        "name": "leaf", "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True,
        "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "baseColorTexture": {"index": 0},
                                 "metallicFactor": 0.0, "roughnessFactor": 0.7},
    }],
    "textures": [{"source": 0}],
    "images": [{"uri": "data:image/png;base64," + base64.b64encode(png.getvalue()).decode()}],
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": n * 12},
        {"buffer": 0, "byteOffset": n * 12, "byteLength": n * 8},
        {"buffer": 0, "byteOffset": n * 20, "byteLength": len(indices) * 12},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
         "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
        {"bufferView": 1, "componentType": 5126, "count": n, "type": "VEC2"},
        {"bufferView": 2, "componentType": 5125, "count": len(indices) * 3, "type": "SCALAR"},
    ],
}
with open("cards.gltf", "w") as f:
    json.dump(gltf, f, indent=1)
print(f"{len(indices)} triangles, coverage {inside.mean():.3f}")
