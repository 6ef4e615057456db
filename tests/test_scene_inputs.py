"""Inputs a researcher brings: an OBJ mesh renders like the same geometry given as PLY (same
triangles, normals and uvs: the same image to float rounding), and a texture that would be silently ignored is a warning
naming the object: the scene does not declare "textures", or the mesh has no texture coordinates. A scene's lights:
more than 8 are refused when read (truth and render), and with 8 every renderer counts all of them. An albedo
outside [0, 1] is refused, from a material, a checker, a float texture or a PLY's vertex colours. A cube
without normals on 8 shared corners (PLY or OBJ) renders as the flat-faced cube, in the truth and every model
(normals with creases); so does the cube as a glTF without NORMAL (flat normals, as glTF 2.0 asks), alone or
beside a primitive with NORMAL, unless subdivided (shared vertices: the subdivision's smooth normals)."""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report, write_gltf, write_ply  # noqa: E402

import numpy as np  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

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
write_ply(ply, [(0, 0, 0, 0, 0, 1, 0, 0), (1, 0, 0, 0, 0, 1, 1, 0), (1, 1, 0, 0, 0, 1, 1, 1), (0, 1, 0, 0, 0, 1, 0, 1)],
          [(0, 1, 2, 3)], extra=("nx", "ny", "nz", "u", "v"))
p2 = truth(scene("ply_tex", {"ply": ply}, ["textures"]), os.path.join(TMP, "b.exr"))
diff = float(np.abs(img - read_image(os.path.join(TMP, "b.exr"))).max()) if p2.returncode == 0 and img is not None else 1
report("the OBJ quad renders as the same quad given as PLY (to float rounding: 1e-6)", diff <= 1e-6,
       f"max difference {diff}; {p2.stderr}")
# A glTF's own material: baseColorFactor and an embedded PNG baseColorTexture, against the same quad
# as PLY with the factor as the scene colour and the same PNG as the scene texture (glTF's v runs
# down the image, the scene textures' up: the PLY's v is 1 - the glTF's): the same image.
import struct  # noqa: E402

# tests/data/textured_quad.glb (tests/data/make_fixtures.py): its PNG, taken out of the binary chunk
# for the scene texture.
glb = os.path.join(DATA, "textured_quad.glb")
raw = open(glb, "rb").read()
json_len = struct.unpack_from("<I", raw, 12)[0]
doc = json.loads(raw[20:20 + json_len])
bin_start = 20 + json_len + 8
view = doc["bufferViews"][doc["images"][0]["bufferView"]]
png_path = os.path.join(TMP, "tex.png")
with open(png_path, "wb") as f:
    f.write(raw[bin_start + view["byteOffset"]:bin_start + view["byteOffset"] + view["byteLength"]])
factor = doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"]
gscene = scene("gltf_tex", {"gltf": glb}, ["textures"], texture=False)
p = truth(gscene, os.path.join(TMP, "g.exr"))
with open(ply, "w") as f:  # the quad again, v flipped
    f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n")
with open(scene("ply_png", {"ply": ply}, ["textures"])) as f:
    s = json.load(f)
s["materials"]["m"] = {"color": factor[:3], "texture": png_path}
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
# "8-bit formats are decoded from sRGB" holds for every 8-bit format, not only for the extensions
# .png and .jpg: the same texels as TGA, BMP and 8-bit TIFF were read as linear (a texel of 200 gave an
# albedo of 0.78 instead of 0.58), so the same texture lit the truth differently by its file's format.
texels = np.array([[[200, 60, 128], [30, 90, 250]], [[120, 180, 10], [240, 5, 70]]], np.uint8)  # mid-range values
h_img = None
for ext in ("png", "tga", "bmp", "tif"):
    tex8 = os.path.join(TMP, "tex8." + ext)
    out8 = oiio.ImageOutput.create(tex8)
    out8.open(tex8, oiio.ImageSpec(2, 2, 3, oiio.UINT8))
    out8.write_image(texels)
    out8.close()
    s["materials"]["m"]["texture"] = tex8
    escene = os.path.join(TMP, f"ply_{ext}.json")
    with open(escene, "w") as f:
        json.dump(s, f)
    p8 = truth(escene, os.path.join(TMP, f"tex8_{ext}.exr"))
    img8 = read_image(os.path.join(TMP, f"tex8_{ext}.exr")) if p8.returncode == 0 else None
    if ext == "png":
        h_img = img8
        continue
    diff = float(np.abs(img8 - h_img).max()) if img8 is not None and h_img is not None else 1
    report(f"an 8-bit {ext.upper()} texture is decoded from sRGB as the same PNG is (the same image; 1e-6)",
           diff <= 1e-6, f"max difference {diff}; {p8.stderr}")
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
# Albedos above 1 (or below 0) are refused wherever a surface's colour comes from: the material's
# color, a checker's color2, a float texture's texels, a PLY's float vertex colours. The truth used
# them as given while heitz-neyret, vmesh and vicini store colours in 8 bits and showed 1 (a plate
# of colour 2 rendered twice as bright in the truth as in those models).
def refused(name, path, words):
    out = os.path.join(TMP, name + ".exr")
    p = subprocess.run([VOXLAB, "truth", path, "--spp", "1", "-o", out], capture_output=True, text=True)
    report(f"{name}: refused naming {words}", p.returncode != 0 and all(w in p.stderr for w in words) and
           not os.path.exists(out), p.stderr[-300:])


def with_material(path, **fields):
    """The scene file at path with its material's fields replaced."""
    with open(path) as f:
        d = json.load(f)
    d["materials"]["m"].update(fields)
    with open(path, "w") as f:
        json.dump(d, f)
    return path


quad_obj = {"obj": os.path.join(DATA, "quad.obj")}
refused("material_colour_above_1", with_material(scene("albedo_2", quad_obj, [], texture=False), color=[2, 0.5, 0.5]),
        ["albedo_2.json: materials.m.color", "expected an albedo", "got 2, 0.5, 0.5"])
p = truth(with_material(scene("albedo_1", quad_obj, [], texture=False), color=[1, 1, 1]),
          os.path.join(TMP, "albedo_1.exr"))
report("a material colour of exactly 1 is accepted", p.returncode == 0, p.stderr[-300:])
refused("checker_colour_above_1", with_material(scene("checker_2", quad_obj, ["textures"]),
                                                texture={"checker": {"scale": 4, "color2": [0.1, 1.5, 0.1]}}),
        ["checker_2.json: materials.m.texture.checker.color2", "expected an albedo"])

texels = np.full((4, 4, 3), 0.5, np.float32)
texels[1, 2, 0] = 1.5
tex = os.path.join(TMP, "bright.exr")
buf = oiio.ImageBuf(oiio.ImageSpec(4, 4, 3, oiio.FLOAT))
buf.set_pixels(oiio.ROI(), texels)
buf.write(tex)
refused("texture_texel_above_1", with_material(scene("texel_2", quad_obj, ["textures"]), texture=tex),
        ["bright.exr: texel 6 (x 2, y 1) channel 0 is 1.5", "expected an albedo"])

ply = os.path.join(TMP, "bright.ply")
write_ply(ply, [(0, 0, 0, 0.5, 0.5, 0.5), (1, 0, 0, 0.5, 1.25, 0.5), (0, 1, 0, 0.5, 0.5, 0.5)], [(0, 1, 2)],
          extra=("red", "green", "blue"))
refused("ply_vertex_colour_above_1", scene("ply_2", {"ply": ply}, [], texture=False),
        ["bright.ply: vertex 1 has a colour channel of 1.25", "expected 0 to 1"])


# A scene's lights: at most LIGHT_MAX_COUNT (8). The tracers hold a voxel's lights in fixed arrays, so
# a scene with more is refused when read (it was lit by its first 8 in every model, beside a truth lit
# by all); with 8, every renderer lights with all 8: without shadows the light adds linearly, so 8
# copies of one light give 8 times its image (the background black, so that only lit surfaces count).
def lights_scene(name, count):
    with open(os.path.join(REPO, "scenes", "spheres.json")) as f:
        s = json.load(f)
    s.update(name=name, background=[0, 0, 0], effects=[], lights=[s["lights"][0]] * count)
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


nine = lights_scene("nine_lights", 9)
models = [line.split()[0] for line in subprocess.run([VOXLAB, "models"], capture_output=True,
                                                    text=True).stdout.splitlines() if line.strip()]
for cmd in (["truth"], ["render", "--model", "binary", "--res", "16"]):
    out = os.path.join(TMP, "nine.exr")
    p = subprocess.run([VOXLAB, cmd[0], nine, *cmd[1:], "--size", "24x24", "-o", out], capture_output=True, text=True)
    report(f"{cmd[0]}: 9 lights are refused, naming the file and the field, with no output",
           p.returncode != 0 and "nine_lights.json: lights: 9 lights; expected at most 8" in p.stderr and
           not os.path.exists(out), p.stderr[-300:])


def lit(path, tag, cmd):
    out = os.path.join(TMP, f"{tag}.exr")
    p = subprocess.run([VOXLAB, cmd[0], path, *cmd[1:], "--size", "24x24", "-o", out], capture_output=True, text=True)
    return read_image(out)[..., :3] if p.returncode == 0 else None


one, eight = lights_scene("one_light", 1), lights_scene("eight_lights", 8)
for name, cmd in [("truth", ["truth", "--spp", "4"])] + [(m, ["render", "--model", m, "--res", "16"]) for m in models]:
    a, b = lit(one, f"one-{name}", cmd), lit(eight, f"eight-{name}", cmd)
    ok = a is not None and b is not None and a.max() > 0.05
    err = float(np.max(np.abs(b - 8 * a)) / max(float(np.max(8 * a)), 1e-9)) if ok else None
    report(f"{name}: 8 copies of a light give 8 times its image (every light counted; relative 1e-5)",
           ok and err <= 1e-5, f"relative difference {err}")

# A mesh without normals gets smooth normals with creases (tracer/scene/mesh.h, MESH_CREASE_DEG): a
# cube written on 8 shared corners (as one writes a cube by hand) renders as the same cube written
# with each face's own corners, in the truth and in every model's bake (the same samples: the same
# image); and so does its OBJ. Before, its corners got the diagonals' normals: the truth lit each
# face only from above its geometric plane while the models, which see the shading normals only,
# lit the faces' upper parts (binary +13 % at 128^3, at every resolution).
CORNERS = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
CUBE_QUADS = [(0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (0, 2, 3, 1), (4, 5, 7, 6)]
shared = os.path.join(TMP, "cube_shared.ply")
write_ply(shared, CORNERS, CUBE_QUADS)  # each face counter-clockwise seen from outside
flat = os.path.join(TMP, "cube_flat.ply")
write_ply(flat, [CORNERS[i] for q in CUBE_QUADS for i in q],
          [(4 * f, 4 * f + 1, 4 * f + 2, 4 * f + 3) for f in range(6)])
cube_obj, flat_obj = os.path.join(TMP, "cube_shared.obj"), os.path.join(TMP, "cube_flat.obj")
with open(cube_obj, "w") as f:
    f.write("".join(f"v {x} {y} {z}\n" for x, y, z in CORNERS))
    f.write("".join("f " + " ".join(str(i + 1) for i in q) + "\n" for q in CUBE_QUADS))
with open(flat_obj, "w") as f:
    f.write("".join(f"v {x} {y} {z}\n" for q in CUBE_QUADS for x, y, z in (CORNERS[i] for i in q)))
    f.write("".join(f"f {4 * k + 1} {4 * k + 2} {4 * k + 3} {4 * k + 4}\n" for k in range(6)))

# The same cubes as glTF (each quad as the triangles (a, b, c), (a, c, d), as the PLY's fan): on the 8
# corners without NORMAL, the flat-faced reference with each face's NORMAL, and a mixed file whose
# first three faces carry NORMAL and whose last three share corners without it. glTF 2.0 asks for flat
# normals where NORMAL is missing; before, such a primitive got smooth ones (the blob of diagonals).
FACE_NORMALS = [(-1, 0, 0), (1, 0, 0), (0, -1, 0), (0, 1, 0), (0, 0, -1), (0, 0, 1)]


def fan(quads):
    return [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]


def flat_faces(faces):
    """A glTF primitive of the cube's faces, each with its own four corners and its NORMAL."""
    return ([CORNERS[i] for f in faces for i in CUBE_QUADS[f]], fan([range(4 * k, 4 * k + 4) for k in range(len(faces))]),
            [FACE_NORMALS[f] for f in faces for _ in range(4)])


cube_gltf, flat_gltf, mixed_gltf = (os.path.join(TMP, f"cube_{k}.gltf") for k in ("shared", "flat", "mixed"))
write_gltf(cube_gltf, [(CORNERS, fan(CUBE_QUADS), None)])
write_gltf(flat_gltf, [flat_faces(range(6))])
write_gltf(mixed_gltf, [flat_faces(range(3)), (CORNERS, fan(CUBE_QUADS[3:]), None)])


def cube_scene(name, obj):
    s = {"name": name, "size": [32, 32], "background": [0.2, 0.3, 0.4], "effects": [],
         "camera": {"position": [0.0, 0.8, 5.0], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 30},
         "lights": [{"type": "directional", "direction": [0.5, 1.0, 0.7], "irradiance": [3, 3, 3]}],
         "materials": {"m": {"color": [0.7, 0.6, 0.5]}},
         "objects": [dict(obj, material="m", transform={"scale": 0.8, "rotate_deg": [30, 30, 0]})]}
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


cubes = {k: cube_scene("cube_" + k, o) for k, o in
         (("shared", {"ply": shared}), ("flat", {"ply": flat}), ("obj", {"obj": cube_obj}),
          ("flat_obj", {"obj": flat_obj}), ("gltf", {"gltf": cube_gltf}), ("flat_gltf", {"gltf": flat_gltf}),
          ("mixed_gltf", {"gltf": mixed_gltf}))}
for name, cmd in [("truth", ["truth", "--spp", "4"])] + [(m, ["render", "--model", m, "--res", "24"]) for m in models]:
    imgs = {}
    for k, path in cubes.items():
        out = os.path.join(TMP, f"cube-{k}-{name}.exr")
        p = subprocess.run([VOXLAB, cmd[0], path, *cmd[1:], "-o", out], capture_output=True, text=True)
        imgs[k] = read_image(out)[..., :3] if p.returncode == 0 else None
    ok = all(v is not None for v in imgs.values())
    # Each format against its own flat cube (the same loader, the same triangulation).
    d = [float(np.abs(imgs[a] - imgs[b]).max()) for a, b in (("shared", "flat"), ("obj", "flat_obj"))] if ok else None
    report(f"{name}: a cube on 8 shared corners without normals (PLY, OBJ) renders as the flat-faced cube (1e-6)",
           ok and max(d) <= 1e-6, f"max differences {d}")
    g = [float(np.abs(imgs[a] - imgs["flat_gltf"]).max()) for a in ("gltf", "mixed_gltf")] if ok else None
    report(f"{name}: a glTF cube on 8 shared corners without NORMAL (alone, or beside a primitive with NORMAL) "
           "renders as the flat-faced cube with NORMAL (1e-6)", ok and max(g) <= 1e-6, f"max differences {g}")
# With "subdivide" a glTF primitive without NORMAL keeps its shared corners (Loop subdivision connects
# by vertex index; split corners would come apart into separate patches): the same image as the cube
# with NORMAL on the same 8 corners, whose given normals the subdivision replaces anyway.
diag_gltf = os.path.join(TMP, "cube_diag.gltf")
write_gltf(diag_gltf, [(CORNERS, fan(CUBE_QUADS), [tuple(c / 3 ** 0.5 for c in p) for p in CORNERS])])
sub = {}
for k, path in (("none", cube_gltf), ("diag", diag_gltf)):
    out = os.path.join(TMP, f"cube-sub-{k}.exr")
    p = truth(cube_scene(f"cube_sub_{k}", {"gltf": path, "subdivide": 1}), out)
    sub[k] = read_image(out)[..., :3] if p.returncode == 0 else None
ok = all(v is not None for v in sub.values())
d = float(np.abs(sub["none"] - sub["diag"]).max()) if ok else None
report("truth: a subdivided glTF cube without NORMAL renders as with NORMAL on the same 8 corners (shared "
       "vertices; 1e-6)", ok and d <= 1e-6, f"max difference {d}")

# A zero normal in a file (PLY nx ny nz = 0, OBJ `vn 0 0 0`) is no direction: the shading takes the
# face's geometric normal, as a file without normals gives a flat quad, whatever the format and
# whether the object is transformed or instanced. (A PLY's zero normal became +z, and an OBJ's did
# once transformed: a plate facing +y was lit as if tangent to its light, 10 times too dark.)
quad_up = [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)]
zero_ply, plain_ply, zero_obj, plain_obj = (os.path.join(TMP, n) for n in
                                            ("zero_normals.ply", "no_normals.ply", "zero_vn.obj", "no_vn.obj"))
write_ply(zero_ply, [v + (0, 0, 0) for v in quad_up], [(0, 1, 2, 3)], extra=("nx", "ny", "nz"))
write_ply(plain_ply, quad_up, [(0, 1, 2, 3)])
with open(zero_obj, "w") as f:
    f.write("".join(f"v {x} {y} {z}\n" for x, y, z in quad_up) + "vn 0 0 0\nf 1//1 2//1 3//1 4//1\n")
with open(plain_obj, "w") as f:
    f.write("".join(f"v {x} {y} {z}\n" for x, y, z in quad_up) + "f 1 2 3 4\n")
zero_gltf, plain_gltf = os.path.join(TMP, "zero_normals.gltf"), os.path.join(TMP, "no_normals.gltf")
write_gltf(zero_gltf, [(quad_up, fan([(0, 1, 2, 3)]), [(0, 0, 0)] * 4)])
write_gltf(plain_gltf, [(quad_up, fan([(0, 1, 2, 3)]), None)])


def plate_scene(name, obj):
    s = {"name": name, "size": [24, 24], "background": [0.2, 0.3, 0.4], "effects": [],
         "camera": {"position": [0.5, 2.5, 2.0], "look_at": [0.5, 0.0, 0.5], "up": [0, 1, 0], "fov_deg": 40},
         "lights": [{"type": "directional", "direction": [0.2, 1.0, 0.1], "irradiance": [3, 3, 3]}],
         "materials": {"m": {"color": [0.5, 0.5, 0.5]}}, "objects": [dict(obj, material="m")]}
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


same = {"scale": 1.0}
plates = {"plain": {"ply": plain_ply}, "plain_obj": {"obj": plain_obj}, "zero_ply": {"ply": zero_ply},
          "zero_ply_moved": {"ply": zero_ply, "transform": same},
          "zero_obj": {"obj": zero_obj}, "zero_obj_moved": {"obj": zero_obj, "transform": same},
          "zero_obj_instanced": {"obj": zero_obj, "instances": [{"translate": [0, 0, 0]}]},
          "plain_gltf": {"gltf": plain_gltf}, "zero_gltf": {"gltf": zero_gltf},
          "zero_gltf_moved": {"gltf": zero_gltf, "transform": same}}
for name, cmd in [("truth", ["truth", "--spp", "4"])] + [(m, ["render", "--model", m, "--res", "16"]) for m in models]:
    imgs = {}
    for k, obj in plates.items():
        out = os.path.join(TMP, f"plate-{k}-{name}.exr")
        p = subprocess.run([VOXLAB, cmd[0], plate_scene("plate_" + k, obj), *cmd[1:], "-o", out], capture_output=True,
                           text=True)
        imgs[k] = read_image(out)[..., :3] if p.returncode == 0 else None
    ok = all(v is not None for v in imgs.values())
    # Each format against its own quad without normals (the same loader, the same triangulation).
    own = {"obj": "plain_obj", "gltf": "plain_gltf"}
    d = {k: float(np.abs(v - imgs[next((p for f, p in own.items() if f in k), "plain")]).max())
         for k, v in imgs.items() if not k.startswith("plain")} if ok else None
    report(f"{name}: a quad with zero normals (PLY, OBJ, glTF; transformed, instanced) renders as without normals "
           "(1e-6)",
           ok and max(d.values()) <= 1e-6, f"max differences {d}")

# A scene small against its distance from the origin (or from its camera) is warned about: float
# positions are coarse there, and the truth's shadow rays start a good part of the scene off its
# surfaces (a 1e-3 scene at 1e3 lost its shadow without a word). The same scene at the origin, and a
# unit scene, load silently.
def tiny_scene(name, at):
    s = {"name": name, "size": [8, 8], "background": [0.2, 0.3, 0.4], "effects": ["shadows"],
         "camera": {"position": [at + 5e-4, at + 2.5e-3, at + 2e-3], "look_at": [at + 5e-4, at, at + 5e-4],
                    "up": [0, 1, 0], "fov_deg": 40},
         "lights": [{"type": "directional", "direction": [0.2, 1.0, 0.1], "irradiance": [3, 3, 3]}],
         "materials": {"m": {"color": [0.5, 0.5, 0.5]}},
         "objects": [{"ply": plain_ply, "material": "m", "transform": {"scale": 1e-3, "translate": [at, at, at]}}]}
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


for name, at, warned in (("tiny_far", 1e3, True), ("tiny_near", 0.0, False)):
    p = subprocess.run([VOXLAB, "truth", tiny_scene(name, at), "--dry-run", "-o", os.path.join(TMP, "t.exr")],
                       capture_output=True, text=True)
    said = "warning" in p.stderr and "float positions are coarse" in p.stderr and name + ".json" in p.stderr
    report(f"a 1e-3 scene {at:g} from the origin: {'a warning' if warned else 'no warning'} about float precision",
           p.returncode == 0 and said == warned, p.stderr.strip()[-400:])
p = subprocess.run([VOXLAB, "truth", plate_scene("plate_unit", {"ply": plain_ply}), "--dry-run", "-o",
                    os.path.join(TMP, "t.exr")], capture_output=True, text=True)
report("a unit scene: no warning about float precision", p.returncode == 0 and "warning" not in p.stderr,
       p.stderr.strip()[-400:])
finish()
