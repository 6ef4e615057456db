"""Precomputed shadows (issue 18: `--shadows march|slicemap|slicemap-model`, tracer/shadows/; issue
15: `--shadows voxel`, march's shadow rays precomputed per voxel, tracer/render/render_voxel.c).

1. A fully lit scene (a ground and nothing over it) gives the same pixels with every method, for
   the truth and for every model.
2. An opaque box's shadow from `slicemap` matches the truth's hard shadow (Embree shadow rays, the
   same primary rays at 1 spp) to within one light-grid cell: every pixel where they disagree lies
   within a cell's width (on the ground) of the truth's shadow boundary.
3. `slicemap-model` with an opaque model (binary) equals `march` within the grid's resolution: the
   shadow masks differ only within a voxel's width of the boundary.
4. No shadow computation when the scene does not declare `shadows`: shadow rays, queries, bytes and
   build time are 0 and the method null whatever --shadows says; the image is march's.
5. The counters and --stats fields of each method; the scene's "shadows" object chooses a method
   and --shadows overrides it; the truth falls back to its shadow rays for slicemap-model.
6. Bad input names the option or field and exits non-zero.
7. Deterministic whatever the thread count; the OpenCL backend gives the C backend's image.
8. The Python API's in-process cache: the same render again takes the maps from the cache (no build
   time); a moved light builds them again.
9. `voxel` gives march's image bit for bit, for every per-voxel model, with a directional and a point
   light (the per-voxel, per-light layout), at 1 and 2 threads, with and without the shadow skip; the
   frame casts no shadow ray and the precomputation is reported (seconds, voxels x lights x 4 bytes);
   the OpenCL backend reads the same precomputation (its image within 1e-4 of the C backend's and of
   its own march, as its march is of the C backend's); a cone model (either backend) and the truth
   refuse it; a scene that declares it gets it, and its truth uses its shadow rays.
10. heitz-neyret's `slicemap-model` approaches its own `march` as --shadow-res grows: columns finer
   than a voxel asked the model for coverage below its voxels' scale, and the maps' distance to the
   march grew with the resolution (the fidelity audit: MSE 6.2e-4 at 48 columns, 1.3e-3 at 768).
(The popcount transmittance (1 - σ)^n of a stack of leaf quads is tests/unit_shadows.c's.)
"""
import json
import math
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report, voxlab  # noqa: E402

# The Python API part loads build*/libvoxlab.so: under `make test-asan` it is ASan's, whose runtime
# must come first (as tests/test_python_api.py does).
if "asan" in os.environ.get("BUILD", "build") and "libasan" not in os.environ.get("LD_PRELOAD", ""):
    _rt = subprocess.run(["gcc", "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    os.execve(sys.executable, [sys.executable, *sys.argv],
              dict(os.environ, LD_PRELOAD=_rt, ASAN_OPTIONS=os.environ.get("ASAN_OPTIONS", "") + ":detect_leaks=0"))

SIZE = (96, 96)
RES = 48
LIGHT = [0.5, 1.0, 0.3]
COS_LIGHT = 1.0 / math.sqrt(sum(c * c for c in LIGHT))  # cosine of the light on the ground


def run(*args):
    return subprocess.run([VOXLAB, *map(str, args)], capture_output=True, text=True)


def write_obj(name, verts, faces):
    path = os.path.join(TMP, name)
    with open(path, "w") as f:
        for v in verts:
            f.write("v %r %r %r\n" % tuple(float(c) for c in v))
        for fc in faces:
            f.write("f " + " ".join(str(i + 1) for i in fc) + "\n")
    return os.path.basename(path)


GROUND = write_obj("sm_ground.obj", [(-5, 0, -5), (-5, 0, 5), (5, 0, 5), (5, 0, -5)], [(0, 1, 2, 3)])
# A unit box standing on the ground, faces wound counter-clockwise seen from outside.
BOX = write_obj("sm_box.obj",
                [(x, y, z) for x in (-0.8, 0.8) for y in (0.0, 1.6) for z in (-0.8, 0.8)],
                [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])


def scene(name, box=True, effects=("shadows",), extra=None):
    s = {"name": name, "size": list(SIZE), "background": [0, 0, 0], "effects": list(effects),
         # Straight down onto the ground: a ground pixel is 2 * 5 tan(30°) / 96 wide.
         "camera": {"position": [0, 5, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "fov_deg": 60},
         "lights": [{"type": "directional", "direction": LIGHT, "irradiance": [3, 3, 3]}],
         "materials": {"grey": {"color": [0.6, 0.6, 0.6]}},
         "objects": [{"obj": GROUND, "material": "grey"}] + ([{"obj": BOX, "material": "grey"}] if box else [])}
    s.update(extra or {})
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


PIXEL = 2 * 5 * math.tan(math.radians(30)) / SIZE[1]


def models():
    return [line.split()[0] for line in voxlab("models").stdout.splitlines() if line.strip()]


def render(spath, name, *args):
    out, st = os.path.join(TMP, name + ".exr"), os.path.join(TMP, name + ".json")
    voxlab("render", spath, "-o", out, "--stats", st, *args)
    with open(st) as f:
        return read_image(out), json.load(f)


def truth(spath, name, *args):
    out, st = os.path.join(TMP, name + ".exr"), os.path.join(TMP, name + ".json")
    voxlab("truth", spath, "-o", out, "--stats", st, *args)
    with open(st) as f:
        return read_image(out), json.load(f)


def within_band(mask, ref, r):
    """Whether mask differs from ref only within r pixels of ref's boundary."""
    from skimage.morphology import binary_dilation, binary_erosion, disk
    inner, outer = binary_erosion(ref, disk(r)), binary_dilation(ref, disk(r))
    return bool(np.all(mask[inner]) and not np.any(mask[~outer]))


def shadow_mask(img):
    lum = img[..., :3].mean(axis=2)
    return lum < 0.5 * lum.max()


METHODS = ("march", "slicemap", "slicemap-model")

# ---------- 1. fully lit ----------
lit = scene("sm_lit", box=False)
base, _ = truth(lit, "lit_truth_march", "--spp", 4, "--shadows", "march")
t2, st = truth(lit, "lit_truth_slicemap", "--spp", 4, "--shadows", "slicemap")
report("fully lit: the truth's slicemap gives the shadow rays' pixels", np.array_equal(base, t2) and
       st["shadow_queries"] > 0, f"max diff {np.abs(base - t2).max()}, {st['shadow_queries']} queries")
vox = {}
for m in models():
    vox[m] = os.path.join(TMP, f"lit_{m}.vox")
    voxlab("bake", lit, "--model", m, "--res", RES, "-o", vox[m])
    imgs = {sm: render(lit, f"lit_{m}_{sm}", "--vox", vox[m], "--shadows", sm)[0] for sm in METHODS}
    same = all(np.array_equal(imgs["march"], imgs[sm]) for sm in METHODS)
    report(f"fully lit: {m} gives the same pixels with every method", same,
           str({sm: float(np.abs(imgs[sm] - imgs['march']).max()) for sm in METHODS}))

# ---------- 2. the box's hard shadow: slicemap against the truth ----------
box = scene("sm_box")
SM_RES = 128
t_march, _ = truth(box, "box_truth_march", "--spp", 1, "--shadows", "march")
t_slice, st = truth(box, "box_truth_slicemap", "--spp", 1, "--shadows", "slicemap", "--shadow-res", SM_RES)
ref, got = shadow_mask(t_march), shadow_mask(t_slice)
# A light-grid cell: at most the bounds' diagonal over the resolution, stretched on the ground by
# 1 / cos of the light.
cell = math.sqrt(10 ** 2 + 1.6 ** 2 + 10 ** 2) / SM_RES / COS_LIGHT
r = math.ceil(cell / PIXEL) + 1
report("the truth has a box shadow to compare", ref.sum() > 200, f"{ref.sum()} shadowed pixels")
report(f"slicemap's box shadow matches the truth's within one light-grid cell ({r} px)",
       within_band(got, ref, r) and got.sum() > 0.8 * ref.sum(),
       f"{int((got != ref).sum())} pixels differ, {got.sum()} vs {ref.sum()} shadowed")
report("slicemap stats: no shadow rays, queries, the resolution asked, bytes and build time",
       st["shadow_method"] == "slicemap" and st["shadow_rays"] == 0 and st["shadow_queries"] > 0 and
       st["shadow_res"] == SM_RES and st["shadow_bytes"] > 0 and st["shadow_build_seconds"] > 0,
       json.dumps({k: v for k, v in st.items() if "shadow" in k}))

# ---------- 3. slicemap-model with an opaque model against march ----------
box_vox = os.path.join(TMP, "box_binary.vox")
voxlab("bake", box, "--model", "binary", "--res", RES, "-o", box_vox)
v_march, st_m = render(box, "box_binary_march", "--vox", box_vox, "--shadows", "march")
v_model, st_s = render(box, "box_binary_smodel", "--vox", box_vox, "--shadows", "slicemap-model")
voxel = 10.0 / RES / COS_LIGHT
r = math.ceil(voxel / PIXEL) + 1
ref, got = shadow_mask(v_march), shadow_mask(v_model)
report(f"slicemap-model (binary) matches march within the grid's resolution ({r} px)",
       ref.sum() > 200 and within_band(got, ref, r) and got.sum() > 0.8 * ref.sum(),
       f"{int((got != ref).sum())} pixels differ, {got.sum()} vs {ref.sum()} shadowed")
report("march counts shadow rays, slicemap-model queries (grid's N by default)",
       st_m["shadow_rays"] > 0 and st_m["shadow_queries"] == 0 and st_m["shadow_method"] == "march" and
       st_s["shadow_rays"] == 0 and st_s["shadow_queries"] > 0 and st_s["shadow_res"] == (3 * RES + 1) // 2 and
       st_s["shadow_bytes"] > 0, json.dumps({k: (st_m[k], st_s[k]) for k in st_m if "shadow" in k}))

# ---------- 4. nothing when shadows are not declared ----------
noshadow = scene("sm_noshadow", effects=())
nvox = os.path.join(TMP, "noshadow_binary.vox")
voxlab("bake", noshadow, "--model", "binary", "--res", 32, "-o", nvox)
plain, _ = render(noshadow, "ns_plain", "--vox", nvox)
for sm in METHODS + ("voxel",):
    img, st = render(noshadow, f"ns_{sm}", "--vox", nvox, "--shadows", sm)
    report(f"no shadows declared: --shadows {sm} computes nothing",
           st["shadow_rays"] == 0 and st["shadow_queries"] == 0 and st["shadow_bytes"] == 0 and
           st["shadow_build_seconds"] == 0 and st["shadow_method"] is None and np.array_equal(img, plain),
           json.dumps({k: v for k, v in st.items() if "shadow" in k}))
_, st = truth(noshadow, "ns_truth", "--spp", 1, "--shadows", "slicemap")
report("no shadows declared: the truth's slicemap computes nothing",
       st["shadow_rays"] == 0 and st["shadow_queries"] == 0 and st["shadow_bytes"] == 0 and
       st["shadow_method"] is None, json.dumps({k: v for k, v in st.items() if "shadow" in k}))

# ---------- 5. the scene's method ----------
chosen = scene("sm_chosen", extra={"shadows": {"method": "slicemap-model", "resolution": 32}})
_, st = render(chosen, "chosen_default", "--vox", box_vox)
report("the scene's shadows object chooses the method and resolution",
       st["shadow_method"] == "slicemap-model" and st["shadow_res"] == 32, str(st["shadow_method"]))
_, st = render(chosen, "chosen_override", "--vox", box_vox, "--shadows", "march")
report("--shadows overrides the scene's method", st["shadow_method"] == "march" and st["shadow_rays"] > 0,
       str(st["shadow_method"]))
_, st = truth(chosen, "chosen_truth", "--spp", 1)
report("the truth of a slicemap-model scene uses its shadow rays",
       st["shadow_method"] == "march" and st["shadow_rays"] > 0, str(st["shadow_method"]))

# ---------- 6. bad input ----------
bad = [
    (("render", box, "--vox", box_vox, "--shadows", "deep", "-o", os.path.join(TMP, "x.exr")), "--shadows deep"),
    (("render", box, "--vox", box_vox, "--shadow-res", 0, "-o", os.path.join(TMP, "x.exr")), "--shadow-res"),
    (("render", box, "--vox", box_vox, "--shadow-res", 5000, "-o", os.path.join(TMP, "x.exr")), "--shadow-res"),
    (("truth", box, "--shadows", "slicemap-model", "-o", os.path.join(TMP, "x.exr")), "slicemap-model"),
    (("truth", scene("sm_bad_method", extra={"shadows": {"method": "soft"}}), "-o", os.path.join(TMP, "x.exr")),
     "shadows.method"),
    (("truth", scene("sm_bad_res", extra={"shadows": {"resolution": 0}}), "-o", os.path.join(TMP, "x.exr")),
     "resolution"),
    (("truth", scene("sm_no_effect", effects=(), extra={"shadows": {"method": "slicemap"}}), "-o",
      os.path.join(TMP, "x.exr")), "does not declare"),
    (("truth", scene("sm_bad_sigma", extra={"materials": {"grey": {"shadow_sigma": 1.5}}}), "-o",
      os.path.join(TMP, "x.exr")), "shadow_sigma"),
    (("truth", scene("sm_inside", extra={"lights": [{"type": "point", "position": [0, 0.5, 0]}]}), "--shadows",
      "slicemap", "-o", os.path.join(TMP, "x.exr")), "lights[0]"),
]
for args, want in bad:
    p = run(*args)
    report(f"bad input refused, naming {want}", p.returncode != 0 and want in p.stderr, p.stderr.strip()[-200:])

# ---------- 7. threads and backends ----------
one, _ = render(box, "box_t1", "--vox", box_vox, "--shadows", "slicemap", "--threads", 1)
two, _ = render(box, "box_t2", "--vox", box_vox, "--shadows", "slicemap", "--threads", 2)
report("slicemap renders do not depend on the thread count", np.array_equal(one, two), "")
# vicini: its own (non-exponential) attenuation rule, applied from the light's side in the maps.
for m in [m for m in ("binary", "alpha", "heitz-neyret", "vicini") if m in models()]:
    bvox = os.path.join(TMP, f"box_{m}.vox")
    if m != "binary":
        voxlab("bake", box, "--model", m, "--res", RES, "-o", bvox)
    for sm in ("slicemap", "slicemap-model"):
        c, sc = render(box, f"box_{m}_{sm}_c", "--vox", bvox, "--shadows", sm)
        o, so = render(box, f"box_{m}_{sm}_cl", "--vox", bvox, "--shadows", sm, "--backend", "opencl")
        diff = float(np.abs(c - o).max())
        report(f"opencl gives the C backend's image: {m}, {sm}", diff <= 1e-4 and so["shadow_queries"] > 0 and
               so["shadow_rays"] == 0 and so["shadow_bytes"] == sc["shadow_bytes"], f"max diff {diff}")

# ---------- 8. the in-process cache ----------
sys.path.insert(0, os.path.join(REPO, "experiments"))
os.environ.setdefault("VOXLAB_LIB", os.path.join(REPO, os.environ.get("BUILD", "build"), "libvoxlab.so"))
import voxlab as api  # noqa: E402

with open(chosen) as f:
    sd = json.load(f)
b, _ = api.bake(sd, "alpha", 32, base_dir=TMP)
i1, s1 = api.render(sd, vox=b, base_dir=TMP)
i2, s2 = api.render(sd, vox=b, base_dir=TMP)
report("the same render again takes the maps from the cache",
       not s1["shadow_cache_hit"] and s1["shadow_build_seconds"] > 0 and s2["shadow_cache_hit"] and
       s2["shadow_build_seconds"] == 0 and np.array_equal(i1, i2), f"{s1['shadow_cache_hit']} {s2['shadow_cache_hit']}")
sd["lights"][0]["direction"] = [-0.4, 1.0, 0.2]
i3, s3 = api.render(sd, vox=b, base_dir=TMP)
report("a moved light builds the maps again", not s3["shadow_cache_hit"] and s3["shadow_build_seconds"] > 0 and
       not np.array_equal(i1, i3), f"{s3['shadow_cache_hit']}")
_, s4 = api.render(sd, vox=b, base_dir=TMP, shadows="march")
_, s5 = api.render(sd, vox=b, base_dir=TMP, shadows="slicemap", shadow_res=64)
report("the Python API's shadows= and shadow_res= are --shadows and --shadow-res",
       s4["shadow_method"] == "march" and s4["shadow_rays"] > 0 and s5["shadow_method"] == "slicemap" and
       s5["shadow_res"] == 64, f"{s4['shadow_method']} {s5['shadow_method']} {s5['shadow_res']}")
for method in ("slicemap-model", "voxel"):  # both need a model's bake
    try:
        api.truth(sd, size=(8, 8), spp=1, base_dir=TMP, shadows=method)
        refused = False
    except api.VoxlabError as e:
        refused = method in str(e)
    report(f"the Python API's truth refuses {method}", refused, "")

# ---------- 9. voxel: march's shadow rays, precomputed per voxel ----------
# Two lights, so that a voxel's transmittances sit at voxel * 2 + light: a directional light (the
# models' opacity memo) and a point light (each voxel its own direction, no memo).
two = scene("sm_two_lights", extra={"lights": [{"type": "directional", "direction": LIGHT, "irradiance": [2, 2, 2]},
                                               {"type": "point", "position": [-3.0, 4.0, 2.0],
                                                "intensity": [30, 30, 30]}]})
compositing = {line.split()[0]: line.split()[3] for line in voxlab("models").stdout.splitlines() if line.strip()}
for m in models():
    mvox = os.path.join(TMP, f"two_{m}.vox")
    voxlab("bake", two, "--model", m, "--res", RES, "-o", mvox)
    if compositing[m] == "coverage":  # cone marching: no voxels to precompute
        p = run("render", two, "--vox", mvox, "--shadows", "voxel", "-o", os.path.join(TMP, "x.exr"))
        report(f"voxel: {m} (cones) is refused, saying why", p.returncode != 0 and "--shadows voxel" in p.stderr and
               "cones" in p.stderr and not os.path.exists(os.path.join(TMP, "x.exr")), p.stderr.strip()[-200:])
        # Before anything is baked: --dry-run, which bakes nothing, refuses it too.
        p = run("render", two, "--model", m, "--res", 1024, "--shadows", "voxel", "--dry-run", "-o",
                os.path.join(TMP, "x.exr"))
        report(f"voxel: {m} is refused before the bake (--dry-run)", p.returncode != 0 and "cones" in p.stderr,
               p.stderr.strip()[-200:])
        continue
    for extra in ((), ("--no-shadow-skip",)):
        tag = "".join(extra).strip("-")
        v_m, s_m = render(two, f"two_{m}_march{tag}", "--vox", mvox, "--shadows", "march", *extra)
        same = True
        for threads in (1, 2):
            v_v, s_v = render(two, f"two_{m}_voxel{tag}_{threads}", "--vox", mvox, "--shadows", "voxel",
                              "--threads", threads, *extra)
            same = same and np.array_equal(v_m, v_v)
        report(f"voxel gives march's image bit for bit: {m} {' '.join(extra)}(2 lights, 1 and 2 threads)",
               same and s_m["shadow_rays"] > 0, f"max diff {float(np.abs(v_m - v_v).max())}, "
               f"{s_m['shadow_rays']} shadow rays in march's frame")
    report(f"voxel stats: {m}: no shadow ray in the frame, the precomputation's seconds and bytes",
           s_v["shadow_method"] == "voxel" and s_v["shadow_rays"] == 0 and s_v["shadow_res"] is None and
           s_v["shadow_build_seconds"] > 0 and s_v["shadow_bytes"] == s_v["voxels"] * 2 * 4,
           json.dumps({k: v for k, v in s_v.items() if "shadow" in k or k == "voxels"}))
# The shadows matter in that scene: march's image is not the unshadowed one.
with open(two) as f:
    plain = scene("sm_two_plain", effects=(), extra={"lights": json.load(f)["lights"]})
voxlab("bake", plain, "--model", "binary", "--res", RES, "-o", os.path.join(TMP, "two_plain_binary.vox"))
unshadowed, _ = render(plain, "two_plain", "--vox", os.path.join(TMP, "two_plain_binary.vox"))
shadowed, _ = render(two, "two_binary_march_again", "--vox", os.path.join(TMP, "two_binary.vox"))
report("the two-light scene has shadows to precompute (binary: march differs from unshadowed)",
       float(np.abs(shadowed - unshadowed).max()) > 0.1, f"max diff {float(np.abs(shadowed - unshadowed).max())}")
for m in [m for m in ("binary", "vmesh", "vicini") if m in models()]:
    mvox = os.path.join(TMP, f"two_{m}.vox")
    c_v, _ = render(two, f"two_{m}_voxel_c", "--vox", mvox, "--shadows", "voxel")
    cl_v, s_clv = render(two, f"two_{m}_voxel_cl", "--vox", mvox, "--shadows", "voxel", "--backend", "opencl")
    cl_m, s_clm = render(two, f"two_{m}_march_cl", "--vox", mvox, "--shadows", "march", "--backend", "opencl")
    d_c, d_m = float(np.abs(cl_v - c_v).max()), float(np.abs(cl_v - cl_m).max())
    report(f"voxel on OpenCL: {m} within 1e-4 of the C backend's and of OpenCL's march, no shadow ray in its frame",
           d_c <= 1e-4 and d_m <= 1e-4 and s_clv["shadow_method"] == "voxel" and s_clv["shadow_rays"] == 0 and
           s_clm["shadow_rays"] > 0 and s_clv["shadow_build_seconds"] > 0 and
           s_clv["shadow_bytes"] == s_clv["voxels"] * 2 * 4, f"max diff {d_c} (C), {d_m} (march)")
hn_vox = os.path.join(TMP, "two_heitz-neyret.vox")
if os.path.exists(hn_vox):
    p = run("render", two, "--vox", hn_vox, "--shadows", "voxel", "--backend", "opencl", "-o", os.path.join(TMP, "x_cl.exr"))
    report("voxel on OpenCL: heitz-neyret (cones) is refused, saying why", p.returncode != 0 and "cones" in p.stderr and
           not os.path.exists(os.path.join(TMP, "x_cl.exr")), p.stderr.strip()[-200:])
p = run("truth", two, "--shadows", "voxel", "-o", os.path.join(TMP, "x_t.exr"))
report("the truth refuses --shadows voxel", p.returncode != 0 and "voxel" in p.stderr and
       not os.path.exists(os.path.join(TMP, "x_t.exr")), p.stderr.strip()[-200:])
declared = scene("sm_declared_voxel", extra={"shadows": {"method": "voxel"}})
_, st = render(declared, "declared_voxel", "--vox", box_vox)
report("a scene that declares voxel gets it", st["shadow_method"] == "voxel" and st["shadow_rays"] == 0 and
       st["shadow_bytes"] > 0, str(st["shadow_method"]))
_, st = truth(declared, "declared_voxel_truth", "--spp", 1)
report("the truth of a voxel scene uses its shadow rays", st["shadow_method"] == "march" and st["shadow_rays"] > 0,
       str(st["shadow_method"]))
_, s6 = api.render(sd, vox=b, base_dir=TMP, shadows="voxel")
report("the Python API's render takes shadows=\"voxel\"", s6["shadow_method"] == "voxel" and
       s6["shadow_rays"] == 0 and s6["shadow_build_seconds"] > 0, str(s6["shadow_method"]))
# ---------- 10. heitz-neyret's slicemap-model converges with --shadow-res ----------
if "heitz-neyret" in models():
    hn_box = os.path.join(TMP, "box_heitz-neyret.vox")
    if not os.path.exists(hn_box):
        voxlab("bake", box, "--model", "heitz-neyret", "--res", RES, "-o", hn_box)
    hn_march, _ = render(box, "hn_conv_march", "--vox", hn_box, "--shadows", "march")
    dist = {}
    for r in (2 * RES, 16 * RES):
        img, _ = render(box, f"hn_conv_{r}", "--vox", hn_box, "--shadows", "slicemap-model", "--shadow-res", r)
        dist[r] = float(np.mean((img - hn_march) ** 2))
    report(f"heitz-neyret slicemap-model: 16x the columns comes no farther from its march than 2x ({dist})",
           dist[16 * RES] <= 1.25 * dist[2 * RES], str(dist))

finish()
