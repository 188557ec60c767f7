"""Writes tiles.gltf: a 4 x 4 m tiled floor and a 0.5 m sphere whose metalness and roughness
come from glTF metallic-roughness textures (G roughness, B metallic, as real PBR assets store
them), with the factors left at 1 as exporters leave them, a normal texture on the floor
(bevelled grout, chiselled stone tiles), vertex colours on the sphere, and a sign whose emissive texture glows in three bars, embedded as data URIs (the repository ignores *.png), for
scenes/extra/metal-tiles.toml. Deterministic (no random numbers).

Run from this folder: python3 make.py   (needs numpy and Pillow)"""
import base64, io, json
import numpy as np
from PIL import Image


def png_uri(rgb):
    png = io.BytesIO()
    Image.fromarray((np.clip(rgb, 0, 1) * 255).round().astype(np.uint8), "RGB").save(png, format="PNG")
    return "data:image/png;base64," + base64.b64encode(png.getvalue()).decode()


N = 256
y, x = np.mgrid[0:N, 0:N]
u, v = (x + 0.5) / N, (y + 0.5) / N
# Floor: 8 x 8 tiles, polished metal (roughness 0.2) and rough stone (0.85) in a checker, with
# 2 % grout lines of rough stone.
cu, cv = u * 8, v * 8
grout = (np.abs(cu - np.round(cu)) < 0.08) | (np.abs(cv - np.round(cv)) < 0.08)
metal = ((np.floor(cu) + np.floor(cv)) % 2 == 0) & ~grout
floor_mr = np.stack([0 * u, np.where(metal, 0.2, 0.85), metal.astype(float)], -1)
floor_color = np.where(metal[..., None], [0.95, 0.78, 0.55], [0.55, 0.52, 0.48])
# Floor relief, as a normal texture (tangent space: x along +u, y the image's up, -v): the grout
# 4 mm below the tiles with 1.5 cm bevels, and the stone tiles domed (8 mm) and chiselled
# (4 mm ripples 8 cm apart: slopes up to 17°).
size = 4.0  # metres per unit of u and v
eu, ev = np.abs(cu - np.round(cu)) / 8 * size, np.abs(cv - np.round(cv)) / 8 * size  # metres to the grout's centre line
edge = np.minimum(eu, ev)
h = -0.004 * np.clip(1 - (edge - 0.01) / 0.015, 0, 1)
fu, fv = cu - np.floor(cu), cv - np.floor(cv)
stone = 0.008 * np.sin(np.pi * fu) * np.sin(np.pi * fv) + 0.004 * np.sin(2 * np.pi * 6 * fu) * np.sin(2 * np.pi * 5 * fv)
h += np.where(metal, 0.0, stone)
du = (np.roll(h, -1, 1) - np.roll(h, 1, 1)) / (2 * size / N)
dv = (np.roll(h, -1, 0) - np.roll(h, 1, 0)) / (2 * size / N)
n = np.stack([-du, dv, np.ones_like(h)], -1)
floor_normal = (n / np.linalg.norm(n, axis=-1, keepdims=True) + 1) / 2

# Sphere: 6 bands in v, alternating smooth metal (0.1) and rough dielectric (0.6).
band = (np.floor(v * 6) % 2 == 0)
sphere_mr = np.stack([0 * u, np.where(band, 0.1, 0.6), band.astype(float)], -1)
sphere_color = np.where(band[..., None], [0.9, 0.9, 0.92], [0.7, 0.15, 0.1])

# Sign: a glowing panel whose emissive texture is three warm bars on a dark ground (emissive
# factor 1, strength 6 via KHR_materials_emissive_strength).
sign_emissive = np.where((np.abs(v - 0.5) < 0.3) & (np.floor(u * 7) % 2 == 1), 1.0, 0.02)[..., None] * [1.0, 0.75, 0.45]

# Floor quad (y = 0), uvs over [0, 1]^2.
fpos = np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], np.float32)
fnrm = np.tile(np.array([0, 1, 0], np.float32), (4, 1))
fuv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
fidx = np.array([0, 2, 1, 0, 3, 2], np.uint32)
# UV sphere, radius 0.5, centre (0.3, 0.5, -0.2): 48 x 24 quads.
S, R = 48, 24
th, ph = np.meshgrid(np.linspace(0, np.pi, R + 1), np.linspace(0, 2 * np.pi, S + 1), indexing="ij")
n = np.stack([np.sin(th) * np.cos(ph), np.cos(th), -np.sin(th) * np.sin(ph)], -1).reshape(-1, 3)
spos = (0.5 * n + [0.3, 0.5, -0.2]).astype(np.float32)
snrm = n.astype(np.float32)
suv = np.stack([ph / (2 * np.pi), th / np.pi], -1).reshape(-1, 2).astype(np.float32)
# Vertex colours (COLOR_0, linear, a factor of the base colour): warm at the top, cool below.
t = ((n[:, 1] + 1) / 2)[:, None]
scol = (t * [1.0, 0.85, 0.7] + (1 - t) * [0.6, 0.8, 1.0]).astype(np.float32)
sidx = []
for i in range(R):
    for j in range(S):
        a, b = i * (S + 1) + j, (i + 1) * (S + 1) + j
        if i > 0:
            sidx += [a, b, a + 1]
        if i < R - 1:
            sidx += [a + 1, b, b + 1]
sidx = np.array(sidx, np.uint32)
# Sign quad, 0.8 x 0.4 m, standing 0.35 m above the floor's back left, facing +z (its front).
gpos = np.array([[-1.4, 0.35, -1.2], [-0.6, 0.35, -1.2], [-0.6, 0.75, -1.2], [-1.4, 0.75, -1.2]], np.float32)
gnrm = np.tile(np.array([0, 0, 1], np.float32), (4, 1))
guv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
gidx = np.array([0, 1, 2, 0, 2, 3], np.uint32)

arrays = [fpos, fnrm, fuv, fidx, spos, snrm, suv, sidx, gpos, gnrm, guv, gidx, scol]
views, buf = [], b""
for a in arrays:
    views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": a.nbytes})
    buf += a.tobytes()
kind = {1: "SCALAR", 2: "VEC2", 3: "VEC3"}
accessors = []
for k, a in enumerate(arrays):
    acc = {"bufferView": k, "componentType": 5125 if a.dtype == np.uint32 else 5126,
           "count": a.size if a.ndim == 1 else len(a), "type": kind[1 if a.ndim == 1 else a.shape[1]]}
    if k in (0, 4, 8):
        acc["min"], acc["max"] = a.min(0).tolist(), a.max(0).tolist()
    accessors.append(acc)


def material(name, color_tex, mr_tex, normal_tex=None):
    # Factors at 1 (metallicFactor and roughnessFactor default to 1): the texture alone decides.
    m = {"name": name, "pbrMetallicRoughness": {"baseColorTexture": {"index": color_tex},
                                                "metallicRoughnessTexture": {"index": mr_tex}}}
    if normal_tex is not None:
        m["normalTexture"] = {"index": normal_tex}
    return m


gltf = {
    "asset": {"version": "2.0", "generator": "glimpse scenes/extra/metal-tiles/make.py"},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [{"name": "floor", "mesh": 0}, {"name": "sphere", "mesh": 1}, {"name": "sign", "mesh": 2}],
    "meshes": [
        {"name": "floor", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]},
        {"name": "sphere", "primitives": [{"attributes": {"POSITION": 4, "NORMAL": 5, "TEXCOORD_0": 6, "COLOR_0": 12}, "indices": 7, "material": 1}]},
        {"name": "sign", "primitives": [{"attributes": {"POSITION": 8, "NORMAL": 9, "TEXCOORD_0": 10}, "indices": 11, "material": 2}]},
    ],
    "materials": [material("tiles", 0, 1, 4), material("bands", 2, 3),
                  {"name": "sign", "pbrMetallicRoughness": {"baseColorFactor": [0.05, 0.05, 0.05, 1], "metallicFactor": 0},
                   "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 5},
                   "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6}}}],
    "extensionsUsed": ["KHR_materials_emissive_strength"],
    "textures": [{"source": k} for k in range(6)],
    "images": [{"uri": png_uri(t)} for t in (floor_color, floor_mr, sphere_color, sphere_mr, floor_normal, sign_emissive)],
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
    "bufferViews": views,
    "accessors": accessors,
}
with open("tiles.gltf", "w") as f:
    json.dump(gltf, f, indent=1)
print(f"{(len(fidx) + len(sidx) + len(gidx)) // 3} triangles; floor metal {metal.mean():.3f}, sphere metal {band.mean():.3f}")
