"""Inputs a researcher brings: an OBJ mesh renders like the same geometry given as PLY (same
triangles, normals and uvs: the same image to float rounding), and a texture that would be silently ignored is a warning
naming the object: the scene does not declare "textures", or the mesh has no texture coordinates."""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report  # noqa: E402

import numpy as np  # noqa: E402

DATA = os.path.join(REPO, "tests", "data")


def scene(name, obj, effects, texture=True):
    s = {"name": name, "size": [24, 24], "background": [0.2, 0.3, 0.4], "effects": effects,
         "camera": {"position": [0.5, 0.5, 2.0], "look_at": [0.5, 0.5, 0.0], "up": [0, 1, 0], "fov_deg": 40},
         "lights": [{"type": "directional", "direction": [0.2, 0.3, 1.0], "irradiance": [2, 2, 2]}],
         "materials": {"m": {"color": [0.8, 0.7, 0.6]}},
         "objects": [dict(obj, material="m")]}
    if texture:
        s["materials"]["m"]["texture"] = {"checker": {"scale": 4, "color2": [0.1, 0.1, 0.1]}}
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def truth(path, out):
    return subprocess.run([VOXLAB, "truth", path, "--spp", "4", "-o", out], capture_output=True, text=True)


# An OBJ quad with uvs and the textured checker: no warning, textured (two colours on screen).
p = truth(scene("obj_tex", {"obj": os.path.join(DATA, "quad.obj")}, ["textures"]), os.path.join(TMP, "a.exr"))
img = read_image(os.path.join(TMP, "a.exr")) if p.returncode == 0 else None
report("OBJ with vt and a declared texture: renders, no warning, the checker shows",
       p.returncode == 0 and "warning" not in p.stderr and img is not None and len(np.unique(img[8:16, 8:16, 0])) > 2,
       p.stderr)
# The same quad as PLY (same four corners, normals, uvs): the same image.
ply = os.path.join(TMP, "quad.ply")
with open(ply, "w") as f:
    f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n")
p2 = truth(scene("ply_tex", {"ply": ply}, ["textures"]), os.path.join(TMP, "b.exr"))
diff = float(np.abs(img - read_image(os.path.join(TMP, "b.exr"))).max()) if p2.returncode == 0 and img is not None else 1
report("the OBJ quad renders as the same quad given as PLY (to float rounding: 1e-6)", diff <= 1e-6,
       f"max difference {diff}; {p2.stderr}")
# A glTF's own material: baseColorFactor and an embedded PNG baseColorTexture, against the same quad
# as PLY with the factor as the scene colour and the same PNG as the scene texture (glTF's v runs
# down the image, the scene textures' up: the PLY's v is 1 - the glTF's): the same image.
import io  # noqa: E402
import struct  # noqa: E402

from PIL import Image  # noqa: E402

png_path = os.path.join(TMP, "tex.png")
Image.fromarray(np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]], dtype=np.uint8)).save(png_path)
png = open(png_path, "rb").read()
corners = [(0, 0), (1, 0), (1, 1), (0, 1)]
blob = b"".join(struct.pack("<3f", x, y, 0) for x, y in corners)
blob += b"".join(struct.pack("<3f", 0, 0, 1) for _ in corners)
blob += b"".join(struct.pack("<2f", x, 1 - y) for x, y in corners)
blob += struct.pack("<6H", 0, 1, 2, 0, 2, 3)
offset = len(blob)
blob += png + b"\0" * (-len(png) % 4)
doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
       "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                   "material": 0}]}],
       "materials": [{"name": "tinted", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.9, 0.7, 1.0],
                                                                 "baseColorTexture": {"index": 0}}}],
       "textures": [{"source": 0}], "images": [{"bufferView": 4, "mimeType": "image/png"}],
       "buffers": [{"byteLength": len(blob)}],
       "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 48},
                       {"buffer": 0, "byteOffset": 96, "byteLength": 32}, {"buffer": 0, "byteOffset": 128, "byteLength": 12},
                       {"buffer": 0, "byteOffset": offset, "byteLength": len(png)}],
       "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                     {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                     {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                     {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
js = json.dumps(doc).encode()
js += b" " * (-len(js) % 4)
glb = os.path.join(TMP, "textured.glb")
with open(glb, "wb") as f:
    f.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(blob)))
    f.write(struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(blob), b"BIN\0") + blob)
gscene = scene("gltf_tex", {"gltf": glb}, ["textures"], texture=False)
p = truth(gscene, os.path.join(TMP, "g.exr"))
with open(ply, "w") as f:  # the quad again, v flipped
    f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n")
with open(scene("ply_png", {"ply": ply}, ["textures"])) as f:
    s = json.load(f)
s["materials"]["m"] = {"color": [0.5, 0.9, 0.7], "texture": png_path}
pscene = os.path.join(TMP, "ply_png.json")
with open(pscene, "w") as f:
    json.dump(s, f)
p2 = truth(pscene, os.path.join(TMP, "h.exr"))
ok = p.returncode == 0 and p2.returncode == 0
g_img = read_image(os.path.join(TMP, "g.exr")) if ok else None
diff = float(np.abs(g_img - read_image(os.path.join(TMP, "h.exr"))).max()) if ok else 1
report("glTF baseColorFactor x baseColorTexture renders as the same factor and PNG given to the scene "
       "(orientation, sRGB decoding; 1e-6)", ok and diff <= 1e-6 and len(np.unique(g_img[..., 0])) > 3,
       f"max difference {diff}; {p.stderr} {p2.stderr}")
p = truth(scene("gltf_nofx", {"gltf": glb}, [], texture=False), os.path.join(TMP, "i.exr"))
report("a glTF texture without the \"textures\" effect is a warning too", p.returncode == 0 and "objects[0]" in p.stderr
       and '"textures" effect' in p.stderr, p.stderr)

# A texture without the effect: a warning naming the object, and the render goes on.
p = truth(scene("no_effect", {"obj": os.path.join(DATA, "quad.obj")}, []), os.path.join(TMP, "c.exr"))
report("a texture without the \"textures\" effect is a warning naming the object",
       p.returncode == 0 and "warning:" in p.stderr and "objects[0]" in p.stderr and '"textures" effect' in p.stderr,
       p.stderr)
# A texture on a mesh without uvs.
nouv = os.path.join(TMP, "nouv.obj")
with open(nouv, "w") as f:
    f.write("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
p = truth(scene("no_uv", {"obj": nouv}, ["textures"]), os.path.join(TMP, "d.exr"))
report("a texture on a mesh without texture coordinates is a warning naming the object",
       p.returncode == 0 and "objects[0]" in p.stderr and "no texture coordinates" in p.stderr, p.stderr)
# No texture at all: silence.
p = truth(scene("plain", {"obj": nouv}, [], texture=False), os.path.join(TMP, "e.exr"))
report("no texture, no warning", p.returncode == 0 and "warning" not in p.stderr, p.stderr)
finish()
