"""Animated scenes and moving records (issue 17) through the command line: --frame / --frames on
truth and render, frame 0 of an animated scene equal to its static render with every filter (and
any scene without animation unchanged by --filter rebake), nearest/split8 close to the re-bake
(vicini, heitz-neyret, vmesh), bad animation input refused with the field named and nothing
written, and scenes/dynamic.json being scenes/dynamic.py's output. (The fallback of a model
without transform/combine: tests/unit_vmesh_move.c.)"""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, finish, read_image, report, voxlab  # noqa: E402

import numpy as np  # noqa: E402

PLATE = os.path.join(REPO, "scenes", "meshes", "plate.ply")


def write(name, s):
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def base(objects, frames=None):
    s = {"name": "dyn", "size": [40, 40], "background": [0.3, 0.4, 0.5], "effects": ["shadows"],
         "camera": {"position": [0.0, 2.2, 3.4], "look_at": [0, 0.3, 0], "up": [0, 1, 0], "fov_deg": 45},
         "lights": [{"type": "directional", "direction": [0.4, 1.0, 0.3], "irradiance": [3, 3, 3]}],
         "materials": {"g": {"color": [0.7, 0.7, 0.7]}, "r": {"color": [0.8, 0.3, 0.2]}},
         "objects": objects}
    if frames is not None:
        s["frames"] = frames
    return s


GROUND = {"ply": PLATE, "material": "g", "transform": {"scale": [3, 1, 3]}}

def cube_obj(anim):
    # A cube from six plates (closed, outward), lifted off the ground: no voxel shared with it.
    faces = [([0, 0.5, 0], [0, 0, 0]), ([0, -0.5, 0], [180, 0, 0]), ([0.5, 0, 0], [0, 0, -90]),
             ([-0.5, 0, 0], [0, 0, 90]), ([0, 0, 0.5], [90, 0, 0]), ([0, 0, -0.5], [-90, 0, 0])]
    return [dict({"ply": PLATE, "material": "r", "transform": {"scale": 0.6, "rotate_deg": r,
                                                                "translate": [t[0] * 0.6, t[1] * 0.6 + 0.8, t[2] * 0.6]}},
                 **({"animation": anim} if anim else {})) for t, r in faces]


SPIN = {"keys": [{"frame": 0}, {"frame": 4, "rotate_deg": [0, 90, 0], "translate": [0.3, 0.1, 0]}]}
anim_scene = write("anim", base([GROUND] + cube_obj(SPIN), [0, 4]))
still_scene = write("still", base([GROUND] + cube_obj(None)))


def run(*args):
    return subprocess.run([os.environ.get("VOXLAB", os.path.join(REPO, "build", "voxlab")), *map(str, args)],
                          capture_output=True, text=True)


def img(p):
    return read_image(p)


def out(name):
    return os.path.join(TMP, name)


# Truth: --frames writes a numbered sequence; frame 0 of it equals the truth without --frame.
voxlab("truth", anim_scene, "--spp", 16, "-o", out("t.exr"))
voxlab("truth", anim_scene, "--spp", 16, "--frames", "0:4", "-o", out("ts.exr"))
names = [out("ts_%04d.exr" % f) for f in range(5)]
report("truth --frames 0:4 writes ts_0000.exr .. ts_0004.exr", all(os.path.exists(n) for n in names))
report("truth: frame 0 of the sequence equals the truth without --frame",
       np.array_equal(img(names[0]), img(out("t.exr"))))
report("truth: the objects move (frame 4 differs from frame 0)", not np.array_equal(img(names[0]), img(names[4])))

# Render: frame 0 of every filter against the static render.
R = ["--res", 24, "--spp", 2]
voxlab("render", anim_scene, "--model", "alpha", *R, "-o", out("static.exr"))
for f in ["rebake", "nearest", "split8"]:
    voxlab("render", anim_scene, "--model", "alpha", *R, "--frame", 0, "--filter", f, "-o", out(f"f0_{f}.exr"),
           "--stats", out(f"f0_{f}.json"))
report("render --frame 0 --filter rebake equals the static render bit for bit",
       np.array_equal(img(out("f0_rebake.exr")), img(out("static.exr"))))
for f in ["nearest", "split8"]:
    report(f"render --frame 0 --filter {f} equals the static render bit for bit",
           np.array_equal(img(out(f"f0_{f}.exr")), img(out("static.exr"))))
    st = json.load(open(out(f"f0_{f}.json")))
    report(f"--stats of --filter {f}: filter_used {f}, transform_seconds, 6 moving objects",
           st.get("filter_used") == f and "transform_seconds" in st and st.get("moving_objects") == 6, str(st))
a, b = img(out("f0_nearest.exr")), img(out("f0_split8.exr"))
report("frame 0 (no motion): split8 equals nearest bit for bit", np.array_equal(a, b))
# heitz-neyret: its MIP levels too (rebuilt per moved frame, the whole bake's at frame 0).
voxlab("render", anim_scene, "--model", "heitz-neyret", *R, "-o", out("hn_static.exr"))
voxlab("render", anim_scene, "--model", "heitz-neyret", *R, "--frame", 0, "--filter", "split8", "-o", out("hn_f0.exr"))
report("heitz-neyret: render --frame 0 --filter split8 equals the static render bit for bit",
       np.array_equal(img(out("hn_f0.exr")), img(out("hn_static.exr"))))

# A scene without animation: --filter rebake renders the same pixels as the plain command.
voxlab("render", still_scene, "--model", "binary", *R, "-o", out("still.exr"))
voxlab("render", still_scene, "--model", "binary", *R, "--filter", "split8", "-o", out("still_s8.exr"))
report("a scene without animation: --filter split8 renders the plain command's pixels",
       np.array_equal(img(out("still.exr")), img(out("still_s8.exr"))))

# Frame 4 (moved and turned): nearest and split8 track the re-bake.
voxlab("truth", anim_scene, "--spp", 16, "--frame", 4, "-o", out("t4.exr"))
for model in ["vicini", "heitz-neyret", "vmesh"]:
    mse = {}
    for f in ["rebake", "nearest", "split8"]:
        voxlab("render", anim_scene, "--model", model, *R, "--frame", 4, "--filter", f, "-o", out(f"{model}_f4_{f}.exr"))
        mse[f] = float(np.mean((img(out(f"{model}_f4_{f}.exr")) - img(out("t4.exr"))) ** 2))
    print("# frame 4 MSE against the truth, %s: %s" % (model, mse))
    # 5x: heitz-neyret's split8 (each record spread over 8 voxels, the coarse levels rebuilt from them)
    # is the farthest, 4.3x its re-bake's since each pixel's cone has its own pixel's width (issue 15:
    # that cut the re-bake's error by 21 % and split8's by 3 %; 3.5x before).
    report("frame 4: nearest and split8 errors against the truth within 5x the re-bake's (%s) %s" % (model, mse),
           mse["nearest"] < 5 * mse["rebake"] + 1e-4 and mse["split8"] < 5 * mse["rebake"] + 1e-4, str(mse))
# A move by about half a voxel on every axis: nearest snaps each record into the nearest cell (the
# dynamic-SVO paper's §3.3). vmesh used to shift its opacity subgrid by the offset inside the cell,
# which at half a cell kept an eighth of it: the cube turned mostly transparent (here 2.5x the
# re-bake's MSE; 5x at 128^3 in the fidelity audit's scene). Now within 1.5x (measured 0.92x).
HALF_RES = 32
half = 0.5 * 3.0 / (HALF_RES - 3)  # half a voxel: the plate spans 3 units, the grid 1.5 cells more each side
half_scene = write("half", base([GROUND] + cube_obj({"keys": [{"frame": 0}, {"frame": 1, "translate": [half] * 3}]}),
                                [0, 1]))
voxlab("truth", half_scene, "--spp", 16, "--frame", 1, "-o", out("half_t.exr"))
mse = {}
for f in ["rebake", "nearest"]:
    voxlab("render", half_scene, "--model", "vmesh", "--res", HALF_RES, "--spp", 2, "--frame", 1, "--filter", f,
           "-o", out(f"half_{f}.exr"))
    mse[f] = float(np.mean((img(out(f"half_{f}.exr")) - img(out("half_t.exr"))) ** 2))
report("vmesh nearest, moved by half a voxel: within 1.5x the re-bake's error %s" % mse,
       mse["nearest"] < 1.5 * mse["rebake"], str(mse))
# The OpenCL backend renders a moved frame as the C backend does (the records are the same).
for model in ["alpha", "heitz-neyret"]:
    for be in ["c", "opencl"]:
        voxlab("render", anim_scene, "--model", model, *R, "--frame", 4, "--filter", "split8", "--backend", be,
               "-o", out(f"{model}_f4_{be}.exr"))
    d = float(np.abs(img(out(f"{model}_f4_opencl.exr")) - img(out(f"{model}_f4_c.exr"))).max())
    report(f"{model}: frame 4 (split8) on OpenCL agrees with C to 1e-4 per pixel ({d:.2g})", d <= 1e-4)
report("frame 4 differs from frame 0 in every filter",
       all(not np.array_equal(img(out(f"vicini_f4_{f}.exr")), img(out(f"f0_{f}.exr"))) for f in ["rebake", "split8"]))

# A model without transform falling back to re-baking (and saying so) is tests/unit_vmesh_move.c's
# check_fallback: every shipped model now has transform/combine.

# --frames on render: numbered images and statistics.
voxlab("render", anim_scene, "--model", "binary", *R, "--frames", "1:2", "--filter", "nearest", "-o", out("seq.png"),
       "--stats", out("seq.json"))
report("render --frames 1:2 writes seq_0001.png, seq_0002.png and their statistics",
       all(os.path.exists(out(n)) for n in ["seq_0001.png", "seq_0002.png", "seq_0001.json", "seq_0002.json"]))

# Bad input: the field named, non-zero exit, nothing written.
bad = [
    ("frames missing", base([GROUND] + cube_obj(SPIN)), "frames: required"),
    ("frames reversed", base([GROUND] + cube_obj(SPIN), [4, 0]), "frames: expected [A, B]"),
    ("keys not an array", base([GROUND] + cube_obj({"keys": 3}), [0, 4]), "animation.keys"),
    ("keys out of order", base([GROUND] + cube_obj({"keys": [{"frame": 3}, {"frame": 1}]}), [0, 4]),
     "keys[1].frame"),
    ("key without frame", base([GROUND] + cube_obj({"keys": [{"translate": [1, 0, 0]}]}), [0, 4]), "missing field \"frame\""),
    ("unknown key field", base([GROUND] + cube_obj({"keys": [{"frame": 0, "rotate": [1, 0, 0]}]}), [0, 4]), "rotate"),
    ("zero scale", base([GROUND] + cube_obj({"keys": [{"frame": 0, "scale": 0}]}), [0, 4]), "scale"),
    ("translate not a vector", base([GROUND] + cube_obj({"keys": [{"frame": 0, "translate": 2}]}), [0, 4]), "translate"),
]
for name, s, want in bad:
    path = write("bad", s)
    o = out("bad.exr")
    if os.path.exists(o):
        os.remove(o)
    p = run("render", path, "--model", "alpha", "--res", 16, "--frame", 0, "-o", o)
    report(f"bad animation ({name}): refused naming {want!r}, nothing written",
           p.returncode != 0 and want in p.stderr and not os.path.exists(o), p.stderr)
for args, want in [(["--frame", 9], "outside the scene's frames [0, 4]"), (["--frames", "3"], "expected A:B"),
                   (["--frames", "3:1"], "before the first"), (["--filter", "cubic"], "expected rebake, nearest or split8")]:
    p = run("render", anim_scene, "--model", "alpha", "--res", 16, *args, "-o", out("bad2.exr"))
    report(f"render {' '.join(map(str, args))}: refused ({want})",
           p.returncode != 0 and want in p.stderr and not os.path.exists(out("bad2.exr")), p.stderr)
p = run("truth", still_scene, "--frame", 1, "-o", out("bad3.exr"))
report("truth --frame 1 on a scene without frames: refused", p.returncode != 0 and "no \"frames\"" in p.stderr, p.stderr)

# The shipped scene is its generator's default output.
gen = os.path.join(TMP, "dynamic_regen.json")
subprocess.run([sys.executable, os.path.join(REPO, "scenes", "dynamic.py"), "-o", gen], check=True)
a = json.load(open(gen))
b = json.load(open(os.path.join(REPO, "scenes", "dynamic.json")))
for o in a["objects"] + b["objects"]:
    o["ply"] = os.path.basename(o["ply"])
report("scenes/dynamic.json is scenes/dynamic.py's default output (12 objects, frames 0..23)",
       a == b and len(b["objects"]) == 13 and b["frames"] == [0, 23])

finish()
