"""Writes the textures of ../textures.xml (the repository ignores *.png and *.exr; these three are
added by hand): normal.png, a raw tangent-space normal map of ripples (slopes up to about 25 degrees),
bars.exr, an emissive texture of four bright bars on a dim ground (linear radiance), and
albedo.png, an asymmetric checker (colour).
Deterministic. Run from this folder: python3 make.py   (needs numpy, Pillow and OpenEXR)"""
import numpy as np
import OpenEXR
from PIL import Image

N = 64
y, x = np.mgrid[0:N, 0:N]
u, v = (x + 0.5) / N, (y + 0.5) / N
# Height h(u, v) over a unit square: ripples along u and v; the normal (-dh/du, +dh/dv, 1) in
# the frame (dp/du, the image's up = -dp/dv, n).
# The phases make the map change under a flip of u or v, so a renderer reading it mirrored
# (or with its y axis the other way) renders another image.
h = 0.02 * np.sin(2 * np.pi * 3 * u + 1.0) + 0.015 * np.sin(2 * np.pi * 2 * v + 0.5)
du = 0.02 * 2 * np.pi * 3 * np.cos(2 * np.pi * 3 * u + 1.0)
dv = 0.015 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * v + 0.5)
n = np.stack([-du, dv, np.ones_like(h)], -1)
n /= np.linalg.norm(n, axis=-1, keepdims=True)
Image.fromarray(((n + 1) / 2 * 255).round().astype(np.uint8), "RGB").save("normal.png")

# Bars: linear radiance 40 (warm) on a ground of 1, as EXR (Mitsuba's bitmap has no scale).
W, H = 32, 8
y, x = np.mgrid[0:H, 0:W]
# Bars in the top half of the image only (the light's far half, its image's up), so a flipped
# lookup moves the light.
bars = (np.where(((x // 4) % 2 == 1) & (y < H // 2), 40.0, 1.0)[..., None] * np.array([1.0, 0.8, 0.6])).astype(np.float32)
OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, {"RGB": bars}).write("bars.exr")
# Albedo: a 4 x 4 grey checker whose top-left cell is red and whose top row is lighter: no flip
# or turn maps it onto itself (sRGB-encoded colour).
cell = (x4 := (np.mgrid[0:N, 0:N][1] * 4 // N)) + (y4 := (np.mgrid[0:N, 0:N][0] * 4 // N))
albedo = np.where((cell % 2 == 0)[..., None], 0.75, 0.35) * np.ones(3)
albedo[(y4 == 0)] *= 1.2
albedo[(x4 == 0) & (y4 == 0)] = [0.8, 0.15, 0.1]
Image.fromarray((np.clip(albedo, 0, 1) ** (1 / 2.2) * 255).round().astype(np.uint8), "RGB").save("albedo.png")
print("normal.png", n.shape, "bars.exr", bars.shape, "albedo.png", albedo.shape)

# colors.ply: a 1.2 x 0.9 m quad (facing +z) whose corners carry linear float vertex colours
# (Mitsuba reads floats as they are; mid-grey 0.5 would be 0.21 if sRGB-decoded): reddish,
# greenish, bluish and grey, so a mirrored or decoded reading shows.
corners = [(-1.5, 0.0, -0.9, 0.6, 0.25, 0.2), (-0.3, 0.0, -0.9, 0.2, 0.6, 0.25), (-0.3, 0.9, -0.9, 0.25, 0.2, 0.6), (-1.5, 0.9, -0.9, 0.5, 0.5, 0.5)]
with open("colors.ply", "w") as f:
    f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n")
    f.write("property float red\nproperty float green\nproperty float blue\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n")
    for c in corners:
        f.write(" ".join(f"{v:g}" for v in c) + "\n")
    f.write("3 0 1 2\n3 0 2 3\n")  # two triangles: the interpolation is the same in both renderers
print("colors.ply", len(corners), "vertices")
