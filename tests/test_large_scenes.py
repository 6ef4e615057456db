"""Issue 19's large scenes and the object field "subdivide": k (Loop subdivision, tracer/scene/
mesh_subdivide.c): bad values refused naming the field, every mesh kind (PLY, OBJ, glTF, generator)
subdivided four times per level, 0 the same scene as no field, and scenes/bunny_dense.json loaded by
the CLI's cheapest path that reports triangles (a 1x1, 1-spp truth with --stats) with its 4.4M
triangles. scenes/city_large.json (10^7 triangles) is loaded by tests/unit_large_scenes.c through
scene_load: the CLI would also build its Embree BVH (about 30 s and 4 GB)."""
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, finish, report, voxlab  # noqa: E402

DATA = os.path.join(REPO, "tests", "data")
PLATE = os.path.join(REPO, "scenes", "meshes", "plate.ply")


def scene(name, obj):
    s = {"name": name, "size": [16, 16], "background": [0.2, 0.3, 0.4],
         "camera": {"position": [0.5, 1.5, 2.0], "look_at": [0.0, 0.0, 0.0], "up": [0, 1, 0], "fov_deg": 40},
         "lights": [{"type": "directional", "direction": [0.2, 1.0, 0.5], "irradiance": [2, 2, 2]}],
         "materials": {"m": {"color": [0.8, 0.7, 0.6]}},
         "objects": [obj]}
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def stats(path, *extra):
    out = os.path.join(TMP, "s.json")
    p = voxlab("truth", path, "--size", "1x1", "--spp", "1", "-o", os.path.join(TMP, "t.exr"), "--stats", out,
               *extra, check=False)
    if p.returncode != 0:
        return None, p
    with open(out) as f:
        return json.load(f), p


# ---------- bad values are refused naming the file and the field ----------
for i, bad in enumerate([-1, 5, 1.5, "3", True, None, [1]]):
    path = scene(f"bad{i}", {"ply": PLATE, "material": "m", "subdivide": bad})
    p = voxlab("truth", path, "--size", "1x1", "-o", os.path.join(TMP, "bad.exr"), check=False)
    report(f"subdivide {json.dumps(bad)}: refused naming the file and objects[0].subdivide",
           p.returncode != 0 and f"bad{i}.json: objects[0].subdivide" in p.stderr and not os.path.exists(
               os.path.join(TMP, "bad.exr")), p.stderr)

# ---------- every kind of object, 4^k triangles; 0 changes nothing ----------
kinds = {"ply": {"ply": PLATE, "material": "m"},
         "obj": {"obj": os.path.join(DATA, "quad.obj"), "material": "m"},
         "gltf": {"gltf": os.path.join(DATA, "quad.gltf"), "material": "m"},
         "generator": {"generator": "spheres", "seed": 3, "material": "m",
                       "params": {"count": 2, "segments": 8, "rings": 4}}}
for kind, obj in kinds.items():
    base, p0 = stats(scene(f"{kind}_plain", obj))
    zero, _ = stats(scene(f"{kind}_0", dict(obj, subdivide=0)))
    two, p2 = stats(scene(f"{kind}_2", dict(obj, subdivide=2)))
    ok = base and zero and two
    report(f"{kind}: subdivide 2 gives 16 times the triangles",
           ok and two["triangles"] == 16 * base["triangles"], (p0.stderr, p2.stderr, base, two))
    report(f"{kind}: subdivide 0 is the scene without the field (same triangles)",
           ok and zero["triangles"] == base["triangles"], (base, zero))

# The scene's identity (what .vox files are checked against) is the same with "subdivide": 0.
a = voxlab("truth", scene("id_plain", kinds["ply"]), "--size", "16x16", "--spp", "1", "-o", os.path.join(TMP, "a.exr"))
b = voxlab("truth", scene("id_zero", dict(kinds["ply"], subdivide=0)), "--size", "16x16", "--spp", "1", "-o",
           os.path.join(TMP, "b.exr"))
cmp = voxlab("compare", os.path.join(TMP, "a.exr"), os.path.join(TMP, "b.exr"), "--json")
prov = json.loads(cmp.stdout)["provenance"]
report("subdivide 0: same scene hash and image as no field",
       prov["a"]["scene_hash"] == prov["b"]["scene_hash"] and json.loads(cmp.stdout)["mse"] == 0, cmp.stdout)

# ---------- the shipped dense bunny ----------
bunny = os.path.join(REPO, "scenes", "bunny_dense.json")
if not os.path.exists(os.path.join(REPO, "..", "shared", "data", "meshes", "bunny.ply")):
    report("bunny_dense # skipped: ../shared/data/meshes/bunny.ply not found", True)
else:
    t = time.monotonic()
    s, p = stats(bunny)
    t = time.monotonic() - t
    print(f"# bunny_dense: {s and s['triangles']} triangles, loaded and traced 1x1 in {t:.1f} s, "
          f"peak RSS {s and s['peak_rss_bytes'] / 2**20:.0f} MiB")
    report("bunny_dense: at least 3e6 triangles (69451 * 4^3 + the plate's 2)",
           s is not None and s["triangles"] >= 3_000_000 and s["triangles"] == 69451 * 64 + 2, p.stderr)
    report("bunny_dense: no zero-area triangles from the subdivision", s is not None and s["degenerate_triangles"] == 0)

finish()
