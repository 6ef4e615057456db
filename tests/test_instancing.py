"""Instancing (issue 19): an object drawn N times ("instances" list or seeded "scatter").

- An instanced scene and the same scene with every instance written out as its own object (the
  instance's placement as the object's "transform") give the same truth image to float rounding:
  the truth intersects Embree instances in the prototype's space, so hit distances and barycentrics
  differ from the expanded mesh's in the last bits (measured: max |difference| ~3e-6 at 16 spp);
  the tolerance is MSE < 1e-10 and at most 0.5 % of the pixels off by more than 1e-4 (a sample that
  grazes a silhouette may land on the other side of an edge in one form). The scene hash is equal.
- The same grid (voxel counts of `bake --stats`) and the same bake, bit for bit (the .vox bytes).
- An animated object beside instanced ones: the same frame in both forms.
- Bad instancing input is refused with the field named, exit 1, nothing written.
- A scatter is deterministic for a seed and different for another.
- Memory: the truth's BVH (Embree's memory monitor, `bvh_bytes` in --stats) of 1000 instances is far
  below the expanded scene's."""
import copy
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report  # noqa: E402

import numpy as np  # noqa: E402

PLATE = os.path.join(REPO, "scenes", "meshes", "plate.ply")
TORUS = os.path.join(REPO, "scenes", "meshes", "torus.ply")


def base_scene(name, objects, effects=("shadows",)):
    return {"name": name, "size": [64, 48], "background": [0.55, 0.7, 0.9], "effects": list(effects),
            "camera": {"orbit": {"distance": 9.0, "elevation_deg": 30, "azimuth_deg": 30}, "look_at": [0, 0.8, 0],
                       "fov_deg": 40},
            "lights": [{"type": "directional", "direction": [0.45, 1.0, 0.3], "irradiance": [3, 3, 3]}],
            "materials": {"grass": {"color": [0.35, 0.45, 0.22]}, "bark": {"color": [0.35, 0.25, 0.17]},
                          "leaf": {"color": [0.25, 0.55, 0.15], "double_sided": True}},
            "objects": objects}


GROUND = {"name": "ground", "ply": PLATE, "material": "grass", "transform": {"scale": [8, 1, 8]}}
TREE = {"generator": "tree", "seed": 3, "params": {"leaves": 150}, "materials": {"bark": "bark", "leaf": "leaf"}}
PLACES = [{"translate": [-2, 0, -1]},
          {"translate": [1.5, 0, 0.5], "rotate_deg": [0, 40, 0], "scale": 1.3},
          {"translate": [0, 0, 2], "rotate_deg": [10, 200, 5], "scale": [1, 0.8, 1.2]},
          {"translate": [2, 0, -2], "scale": [-1, 1, 1]},  # a mirrored copy: reversed winding
          # Shrunk: Embree's point queries take the query's radius into a copy's space unscaled, so
          # without the bake's widening this copy's own-triangle lists lost triangles.
          {"translate": [-1, 0, 1.5], "rotate_deg": [0, 70, 0], "scale": 0.45}]


def expanded(scene):
    """The scene with every "instances" object written out as one object per instance."""
    out = copy.deepcopy(scene)
    objs = []
    for o in scene["objects"]:
        if "instances" in o:
            for x in o["instances"]:
                c = {k: v for k, v in o.items() if k not in ("instances", "name")}
                c["transform"] = x
                objs.append(c)
        else:
            objs.append(o)
    out["objects"] = objs
    return out


def write(name, scene):
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(scene, f)
    return path


def run(*args):
    return subprocess.run([VOXLAB, *map(str, args)], capture_output=True, text=True)


def truth(path, out, *extra):
    stats = out + ".json"
    p = run("truth", path, "--spp", 16, "-o", out, "--stats", stats, *extra)
    if p.returncode != 0:
        return None, None, p.stderr
    with open(stats) as f:
        return read_image(out), json.load(f), ""


def close(a, b):
    if a is None or b is None or a.shape != b.shape:
        return False, "missing image"
    d = np.abs(a.astype(np.float64) - b)
    mse, off = float((d ** 2).mean()), float((d.max(axis=2) > 1e-4).mean())
    return mse < 1e-10 and off <= 0.005, f"mse {mse:.3g}, max {d.max():.3g}, pixels off by >1e-4: {off:.4f}"


# 1. Truth: instanced against written out (shadows on: the shadow packets go through instances too).
inst = base_scene("inst", [GROUND, dict(TREE, instances=PLACES)])
pi, pe = write("inst", inst), write("inst_expanded", expanded(inst))
ai, si, err_i = truth(pi, os.path.join(TMP, "inst.exr"))
ae, se, err_e = truth(pe, os.path.join(TMP, "inst_expanded.exr"))
ok, why = close(ai, ae)
report("truth: instanced == written out (mirrored, rotated, non-uniformly scaled copies; shadows)", ok, why + err_i + err_e)
report("stats: the same triangles, 5 instances of one prototype",
       si is not None and se is not None and si["triangles"] == se["triangles"] and si["instances"] == 5
       and se["instances"] == 0 and si["prototype_triangles"] * 5 + 2 == si["triangles"], f"{si} {se}")
# The scene hash covers the prototypes and every placement: moving one copy by 1e-3 changes it.
moved = json.loads(json.dumps(inst))
moved["objects"][1]["instances"][2]["translate"][0] += 1e-3
pm = write("inst_moved", moved)
_, _, err_m = truth(pm, os.path.join(TMP, "inst_moved.exr"))
p = run("compare", os.path.join(TMP, "inst.exr"), os.path.join(TMP, "inst_moved.exr"), "--json")
prov = json.loads(p.stdout).get("provenance", {}) if p.returncode == 0 else {}
p2 = run("compare", os.path.join(TMP, "inst.exr"), os.path.join(TMP, "inst.exr"), "--json")
prov2 = json.loads(p2.stdout).get("provenance", {}) if p2.returncode == 0 else {}
report("the scene hash follows each instance's placement (one copy moved by 1e-3 changes it)",
       prov and prov2 and prov["a"]["scene_hash"] != prov["b"]["scene_hash"]
       and prov2["a"]["scene_hash"] == prov2["b"]["scene_hash"], p.stdout + p.stderr + err_m)

# The slicemap shadows' columns are Embree rays through the instances too (rtcIntersect1).
bi, _, e1 = truth(pi, os.path.join(TMP, "inst_sm.exr"), "--shadows", "slicemap")
be, _, e2 = truth(pe, os.path.join(TMP, "inst_exp_sm.exr"), "--shadows", "slicemap")
ok, why = close(bi, be)
report("truth --shadows slicemap: instanced == written out", ok, why + e1 + e2)

# 2. Grid and bake: the same voxels and the same .vox bytes.
for model in ("alpha", "binary"):
    vi, ve = os.path.join(TMP, f"inst_{model}.vox"), os.path.join(TMP, f"inst_exp_{model}.vox")
    b1 = run("bake", pi, "--model", model, "--res", 48, "--rays", 32, "-o", vi, "--stats", vi + ".json")
    b2 = run("bake", pe, "--model", model, "--res", 48, "--rays", 32, "-o", ve, "--stats", ve + ".json")
    same = b1.returncode == 0 and b2.returncode == 0
    if same:
        s1, s2 = json.load(open(vi + ".json")), json.load(open(ve + ".json"))
        same = s1["voxels"] == s2["voxels"] and s1["voxels"] > 100
        with open(vi, "rb") as f1, open(ve, "rb") as f2:
            d1, d2 = f1.read(), f2.read()
        # The header names the scene by its hash, which hashes the description (prototypes and
        # placements against written-out copies) and the file's checksum covers it: every other
        # byte, the records above all, must agree.
        differ = [i for i in range(min(len(d1), len(d2))) if d1[i] != d2[i]]
        bytes_same = len(d1) == len(d2) and len(d1) > 1000 and all(i < 64 or i >= len(d1) - 8 for i in differ)
    report(f"grid: instanced and written out have the same voxels ({model} bake --stats)", same, b1.stderr + b2.stderr)
    report(f"bake: the {model} records of both forms are bit-identical (the header's scene hash aside)",
           same and bytes_same, "files differ")

# 3. An animated object beside instanced ones: frame 3 of both forms.
anim = base_scene("inst_anim", [GROUND, dict(TREE, instances=PLACES[:2]),
                                {"ply": TORUS, "material": "bark", "transform": {"scale": 0.5, "translate": [0, 1, 0]},
                                 "animation": {"keys": [{"frame": 0}, {"frame": 4, "translate": [1, 0.5, 0],
                                                                       "rotate_deg": [0, 90, 0]}]}}])
anim["frames"] = [0, 4]
a1, _, e1 = truth(write("inst_anim", anim), os.path.join(TMP, "anim_i.exr"), "--frame", 3)
a2, _, e2 = truth(write("inst_anim_exp", expanded(anim)), os.path.join(TMP, "anim_e.exr"), "--frame", 3)
ok, why = close(a1, a2)
report("animated object beside instances: frame 3 instanced == written out", ok, why + e1 + e2)

# 4. Bad input: refused naming the field, exit 1, no output.
BAD = [
    ("instances not a list", dict(TREE, instances={"translate": [0, 0, 0]}), "objects[1].instances"),
    ("empty instances", dict(TREE, instances=[]), "objects[1].instances"),
    ("zero scale", dict(TREE, instances=[{}, {"scale": 0}]), "objects[1].instances[1].scale"),
    ("unknown instance field", dict(TREE, instances=[{"rotate": [0, 1, 0]}]), "objects[1].instances[0]: unknown field"),
    ("non-numeric translate", dict(TREE, instances=[{"translate": [0, "x", 0]}]), "objects[1].instances[0].translate"),
    ("scatter without count", dict(TREE, scatter={"over": "ground"}), "objects[1].scatter: missing field \"count\""),
    ("scatter count 0", dict(TREE, scatter={"count": 0, "over": "ground"}), "objects[1].scatter.count"),
    ("scatter over an unknown name", dict(TREE, scatter={"count": 3, "over": "grund"}), "objects[1].scatter.over"),
    ("scatter over a bad rect", dict(TREE, scatter={"count": 3, "over": {"rect": [0, 0, 1]}}), "objects[1].scatter.over.rect"),
    ("scatter scale_range reversed", dict(TREE, scatter={"count": 3, "over": "ground", "scale_range": [2, 1]}),
     "objects[1].scatter.scale_range"),
    ("scatter unknown field", dict(TREE, scatter={"count": 3, "over": "ground", "jitter": 1}),
     "objects[1].scatter: unknown field \"jitter\""),
    ("instances and scatter", dict(TREE, instances=[{}], scatter={"count": 3, "over": "ground"}), "objects[1].scatter"),
    ("instanced and animated", dict(TREE, instances=[{}], animation={"keys": [{"frame": 0}]}), "objects[1].animation"),
    ("duplicate name", dict(TREE, name="ground"), "objects[1].name"),
    ("too many copies", dict(TREE, params={"leaves": 20000}, scatter={"count": 1000000, "over": "ground"}),
     "objects[1].scatter"),
]
for what, obj, field in BAD:
    path = write("bad", base_scene("bad", [GROUND, obj]))
    out = os.path.join(TMP, "bad_out.exr")
    if os.path.exists(out):
        os.remove(out)
    p = run("truth", path, "--spp", 1, "-o", out)
    report(f"bad instancing input refused naming the field: {what}",
           p.returncode == 1 and field in p.stderr and path in p.stderr and not os.path.exists(out),
           f"rc {p.returncode}: {p.stderr.strip()}")
anim_ground = base_scene("bad", [dict(GROUND, animation={"keys": [{"frame": 0}]}),
                                 dict(TREE, scatter={"count": 3, "over": "ground"})])
anim_ground["frames"] = [0, 1]
p = run("truth", write("bad", anim_ground), "--spp", 1, "-o", os.path.join(TMP, "bad_out.exr"))
report("scatter over an animated object refused", p.returncode == 1 and "objects[1].scatter.over" in p.stderr, p.stderr)
over_copies = base_scene("bad", [GROUND, dict(TREE, name="tree", instances=[{}]),
                                 dict(TREE, scatter={"count": 3, "over": "tree"})])
p = run("truth", write("bad", over_copies), "--spp", 1, "-o", os.path.join(TMP, "bad_out.exr"))
report("scatter over an instanced object refused (its triangles are its copies')",
       p.returncode == 1 and "objects[2].scatter.over" in p.stderr and "instanced" in p.stderr, p.stderr)

# 5. Scatter: deterministic for a seed, different for another; instances stand on the surface.
def scatter_scene(seed):
    return base_scene("scatter", [GROUND, dict(TREE, scatter={"count": 12, "seed": seed, "over": "ground",
                                                              "scale_range": [0.5, 1.0]})], effects=())


s1, _, e1 = truth(write("sc1", scatter_scene(5)), os.path.join(TMP, "sc1.exr"))
s2, _, e2 = truth(write("sc2", scatter_scene(5)), os.path.join(TMP, "sc2.exr"))
s3, _, e3 = truth(write("sc3", scatter_scene(6)), os.path.join(TMP, "sc3.exr"))
report("scatter: the same seed gives the same image bit for bit",
       s1 is not None and s2 is not None and np.array_equal(s1, s2), e1 + e2)
report("scatter: another seed gives another forest", s1 is not None and s3 is not None and not np.array_equal(s1, s3),
       e1 + e3)

# 6. Memory: 1000 instances against the same 1000 copies written out, the truth's BVH bytes.
rng = np.random.default_rng(4)
many = [{"translate": [float(x), 0.0, float(z)], "rotate_deg": [0, float(r), 0], "scale": float(k)}
        for x, z, r, k in zip(rng.uniform(-40, 40, 1000), rng.uniform(-40, 40, 1000), rng.uniform(0, 360, 1000),
                              rng.uniform(0.7, 1.2, 1000))]
big = base_scene("many", [GROUND, dict(TREE, params={"leaves": 100}, instances=many)], effects=())
_, mi, e1 = truth(write("many", big), os.path.join(TMP, "many.exr"), "--size", "32x32", "--spp", 1)
_, me, e2 = truth(write("many_exp", expanded(big)), os.path.join(TMP, "many_exp.exr"), "--size", "32x32", "--spp", 1)
ok = mi is not None and me is not None and mi["triangles"] == me["triangles"] and mi["bvh_bytes"] * 20 < me["bvh_bytes"]
why = (f"instanced {mi['bvh_bytes']} B, expanded {me['bvh_bytes']} B for {mi['triangles']} triangles"
       if mi and me else e1 + e2)
report(f"memory: 1000 instances' BVH far below the expanded one ({why})", ok, why)
print(f"# {why}")
# The copies are never written out: the whole process, not only the BVH, stays small.
ok = mi is not None and me is not None and mi["peak_rss_bytes"] * 2 < me["peak_rss_bytes"]
why = (f"peak RSS instanced {mi['peak_rss_bytes'] / 2**20:.1f} MiB, written out {me['peak_rss_bytes'] / 2**20:.1f} MiB"
       if mi and me else e1 + e2)
report(f"memory: the instanced scene's truth process under half the written-out one's ({why})", ok, why)
print(f"# {why}")

# 7. The shipped 10^8-triangle forest loads and renders without writing its copies out.
_, mf, ef = truth(os.path.join(REPO, "scenes", "forest_1e8.json"), os.path.join(TMP, "f8.exr"), "--size", "16x16",
                  "--spp", 1)
ok = mf is not None and mf["triangles"] >= 1e8 and mf["instances"] == 4200 and mf["peak_rss_bytes"] < 400 * 2**20
why = f"{mf['triangles']} triangles, {mf['instances']} instances, peak RSS {mf['peak_rss_bytes'] / 2**20:.0f} MiB" if mf else ef
report(f"scenes/forest_1e8.json: >= 10^8 triangles in under 400 MiB ({why})", ok, why)

finish()
