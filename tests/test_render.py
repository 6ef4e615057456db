"""The voxel tracer end to end through the command line: `models`, the .vox round trip and its
error cases, effects, accuracy against the Embree ground truth, determinism, the shading cache and
bad options.

Expectations are independent of the code under test: bit-identity between two paths that must give
the same image, counters that must be zero or not, and accuracy bounds that are checked to be
discriminating (an all-background image and a colour-swapped render must fail them). MSE is also
recomputed here with numpy from the images (read with OpenImageIO's Python bindings)."""
import json
import os
import shutil

import numpy as np

from testlib import REPO, TMP, finish, leftovers, read_image, report, voxlab, write_ply, write_scene

SPHERES = os.path.join(REPO, "scenes", "spheres.json")


def path(name):
    return os.path.join(TMP, name)


def render(scene, out, *args, model="alpha", stats=True):
    """Renders to TMP/out.exr; returns (image, stats dict)."""
    img_path = path(out + ".exr")
    extra = ["--stats", path(out + ".json")] if stats else []
    if model:
        extra += ["--model", model]
    voxlab("render", scene, *args, *extra, "-o", img_path)
    st = None
    if stats:
        with open(path(out + ".json")) as f:
            st = json.load(f)
    return read_image(img_path), st


def compare(a, b):
    return json.loads(voxlab("compare", a, b, "--json").stdout)


def write_pfm(p, img):
    """A float32 PFM (read losslessly by OpenImageIO; bottom row first)."""
    img = np.asarray(img, dtype=np.float32)
    h, w = img.shape[:2]
    with open(p, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())


# ---------- (a) models ----------
p = voxlab("models")
names = [line.split()[0] for line in p.stdout.splitlines() if line.strip()]
report("models lists binary and alpha", "binary" in names and "alpha" in names, p.stdout)

# ---------- (b) .vox round trip: bake + render --vox == render --res, bit for bit ----------
SMALL = ["--size", "48x48", "--spp", "2", "--seed", "5"]
for model in ("alpha", "binary"):
    vox = path(f"rt_{model}.vox")
    voxlab("bake", SPHERES, "--model", model, "--res", "24", "--rays", "32", "--seed", "5", "-o", vox)
    a, _ = render(SPHERES, f"rt_{model}_vox", "--vox", vox, *SMALL, model=None)
    b, _ = render(SPHERES, f"rt_{model}_res", "--res", "24", "--rays", "32", *SMALL, model=model)
    report(f"vox round trip is bit-identical ({model})", np.array_equal(a, b) and a.shape == (48, 48, 3),
           f"max difference {np.abs(a - b).max() if a.shape == b.shape else a.shape}")

# ---------- (c) damaged and mismatched .vox files ----------
good = path("rt_alpha.vox")
raw = open(good, "rb").read()
bad_dir = path("bad")
os.makedirs(bad_dir, exist_ok=True)


def bad_vox(name, data):
    p = os.path.join(bad_dir, name)
    with open(p, "wb") as f:
        f.write(data)
    return p


# The file ends with the records, the grid's cells and an 8-byte checksum (tracer/bake/voxfile.h):
# damage the last byte before the checksum, whatever the header's size.
flipped = bytearray(raw)
flipped[len(raw) - 8 - 1] ^= 0x10
# Another scene: a single quad, baked with the same model.
write_ply(path("quad.ply"), [(-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1)], [(0, 1, 2, 3)])
quad_scene = write_scene("quad", [{"ply": "quad.ply", "material": "grey"}],
                         [{"type": "directional", "direction": [0, 1, 0], "irradiance": [3, 3, 3]}],
                         {"position": [0, 3, 3], "look_at": [0, 0, 0], "fov_deg": 40})
other_scene = os.path.join(bad_dir, "other_scene.vox")
voxlab("bake", quad_scene, "--model", "alpha", "--res", "8", "--rays", "8", "-o", other_scene)
other_model = os.path.join(bad_dir, "other_model.vox")
voxlab("bake", SPHERES, "--model", "binary", "--res", "24", "--rays", "32", "--seed", "5", "-o", other_model)
# A record count of 2^31 - 1 in the header (voxfile.c's disk_header: 8 bytes of magic, then
# voxfile_header, whose record_count sits at byte 72): the file does not hold that many, and must be
# called damaged before `render --vox` estimates its memory from the count (the bad-input audit: it
# was refused as needing 80 GiB, "lower --res, --size or --rays").
huge_count = bytearray(raw)
huge_count[80:88] = (2 ** 31 - 1).to_bytes(8, "little")
cases = [
    ("corrupted byte", bad_vox("corrupt.vox", bytes(flipped)), ["checksum"]),
    ("a record count the file does not hold", bad_vox("huge_count.vox", bytes(huge_count)),
     ["truncated or damaged", "the header promises"]),
    ("truncated", bad_vox("truncated.vox", raw[: len(raw) // 2]), ["truncated"]),
    ("empty file", bad_vox("empty.vox", b""), ["not a voxlab"]),
    ("baked from another scene", other_scene, ["another scene"]),
    ("baked with another model", other_model, ["binary", "alpha"]),
    ("not a vox file", bad_vox("text.vox", b"hello, this is not voxel data\n" * 10), ["not a voxlab"]),
    ("an EXR image", path("rt_alpha_vox.exr"), ["not a voxlab"]),
    ("missing file", os.path.join(bad_dir, "missing.vox"), ["cannot open"]),
]
for what, vox, words in cases:
    out_dir = path("bad_out_" + what.replace(" ", "_"))
    os.makedirs(out_dir, exist_ok=True)
    out = os.path.join(out_dir, "out.exr")
    p = voxlab("render", SPHERES, "--model", "alpha", "--vox", vox, *SMALL, "-o", out,
               "--stats", os.path.join(out_dir, "out.json"), check=False)
    err = p.stderr.strip()
    report(f"bad vox fails with status 1: {what}", p.returncode == 1, f"rc {p.returncode}")
    report(f"bad vox message names the file and the problem: {what}",
           vox in err and all(w in err for w in words) and err.startswith("voxlab render: "), err)
    report(f"bad vox leaves no output: {what}", leftovers(out_dir, "out") == [], str(leftovers(out_dir, "out")))
report("the good file still renders after the bad ones",
       voxlab("render", SPHERES, "--vox", good, *SMALL, "-o", path("good_again.exr"), check=False).returncode == 0)

# ---------- (d) effects: shadows only when declared ----------
with open(SPHERES) as f:
    spheres = json.load(f)
report("spheres declares shadows", "shadows" in spheres["effects"], str(spheres["effects"]))
unshadowed = dict(spheres, effects=[e for e in spheres["effects"] if e != "shadows"])
no_shadow_scene = path("spheres_no_shadows.json")
with open(no_shadow_scene, "w") as f:
    json.dump(unshadowed, f)
EFF = ["--res", "24", "--rays", "32", "--size", "48x48", "--spp", "2"]
for model in ("alpha", "binary"):
    img_s, st_s = render(SPHERES, f"eff_shadow_{model}", *EFF, model=model)
    img_n, st_n = render(no_shadow_scene, f"eff_none_{model}", *EFF, model=model)
    report(f"shadows declared: shadow rays traced ({model})", st_s["shadow_rays"] > 0, str(st_s["shadow_rays"]))
    report(f"shadows removed: no shadow ray ({model})", st_n["shadow_rays"] == 0, str(st_n["shadow_rays"]))
    # Shadows can only take light away (transmittance <= 1; the records do not depend on effects),
    # and the spheres do cast visible shadows on the ground.
    darker = float((img_n - img_s).max())
    report(f"shadows only darken, and visibly ({model})", bool((img_s <= img_n + 1e-6).all()) and darker > 0.05,
           f"brightest gain {float((img_s - img_n).max())}, largest darkening {darker}")

# ---------- (e) accuracy against the ground truth ----------
def metrics(a_path, b_path):
    m = compare(a_path, b_path)
    a, b = read_image(a_path).astype(np.float64), read_image(b_path).astype(np.float64)
    mse = float(np.mean((a - b) ** 2))
    report(f"compare's MSE matches numpy ({os.path.basename(a_path)})", abs(m["mse"] - mse) <= 1e-6 * max(mse, 1e-12),
           f"{m['mse']} vs {mse}")
    return m


# Bounds a working tracer meets with margin at 64^3 (measured: MSE 0.0071 binary, 0.0078 alpha;
# SSIM 0.856, 0.874) and that broken output fails on each criterion alone (checked below: the
# background everywhere scores MSE 0.076, SSIM 0.36; a render with R and B swapped 0.061, 0.76).
MSE_MAX, SSIM_MIN = 0.02, 0.8
truth64 = path("truth64.exr")
voxlab("truth", SPHERES, "--spp", "256", "--size", "64x64", "-o", truth64)
truth_img = read_image(truth64)
scores = {}
for model in ("binary", "alpha"):
    render(SPHERES, f"acc64_{model}", "--res", "64", "--size", "64x64", model=model, stats=False)
    m = metrics(path(f"acc64_{model}.exr"), truth64)
    scores[model] = m
    print(f"# spheres 64^3 {model} vs truth (64x64): MSE {m['mse']:.5f}, SSIM {m['ssim']:.4f}")
    report(f"accuracy at 64^3 ({model}): MSE < {MSE_MAX} and SSIM > {SSIM_MIN}",
           m["mse"] < MSE_MAX and m["ssim"] > SSIM_MIN, str(m))
# The bounds must reject broken images: the background everywhere, a render with R and B swapped.
background = np.broadcast_to(np.array(spheres["background"], np.float32), truth_img.shape)
write_pfm(path("background.pfm"), background)
bg = metrics(path("background.pfm"), truth64)
swapped = read_image(path("acc64_alpha.exr"))[..., ::-1]
write_pfm(path("swapped.pfm"), swapped)
sw = metrics(path("swapped.pfm"), truth64)
print(f"# all-background image: MSE {bg['mse']:.5f}, SSIM {bg['ssim']:.4f}; "
      f"alpha with R/B swapped: MSE {sw['mse']:.5f}, SSIM {sw['ssim']:.4f}")
for what, m in (("all-background image", bg), ("colour-swapped render", sw)):
    report(f"the MSE bound alone rejects an {what}", m["mse"] >= MSE_MAX, str(m))
    report(f"the SSIM bound alone rejects an {what}", m["ssim"] <= SSIM_MIN, str(m))
    for model in scores:
        report(f"{model} scores clearly better than an {what}",
               scores[model]["mse"] < 0.5 * m["mse"] and scores[model]["ssim"] > m["ssim"] + 0.05,
               f"{model} {scores[model]} vs {m}")

# Convergence: alpha's MSE falls with every halving of the voxel size (images 128x128).
truth128 = path("truth128.exr")
voxlab("truth", SPHERES, "--spp", "256", "--size", "128x128", "-o", truth128)
mses = []
for res in (32, 64, 128):
    render(SPHERES, f"conv_{res}", "--res", str(res), "--size", "128x128", model="alpha", stats=False)
    m = metrics(path(f"conv_{res}.exr"), truth128)
    mses.append(m["mse"])
    print(f"# spheres {res}^3 alpha vs truth (128x128): MSE {m['mse']:.5f}, SSIM {m['ssim']:.4f}")
report("alpha's MSE falls strictly 32^3 -> 64^3 -> 128^3", mses[0] > mses[1] > mses[2], str(mses))

# ---------- (f) determinism across thread counts, cache on and off ----------
DET = ["--res", "32", "--rays", "32", "--size", "64x64", "--spp", "2"]
for model in ("alpha", "binary"):
    for cache in ([], ["--no-cache"]):
        tag = "no-cache" if cache else "cache"
        one, _ = render(SPHERES, f"det_{model}_{tag}_1", *DET, "--threads", "1", *cache, model=model, stats=False)
        two, _ = render(SPHERES, f"det_{model}_{tag}_2", *DET, "--threads", "2", *cache, model=model, stats=False)
        report(f"threads 1 and 2 give identical images ({model}, {tag})", np.array_equal(one, two),
               f"max difference {np.abs(one - two).max()}")

# ---------- (g) the shading cache ----------
for model in ("alpha", "binary"):
    on, st_on = render(SPHERES, f"cache_on_{model}", *DET, model=model)
    off, st_off = render(SPHERES, f"cache_off_{model}", *DET, "--no-cache", model=model)
    report(f"--no-cache: no cache hit ({model})", st_off["cache_hits"] == 0 and st_off["cache"] is False,
           f"{st_off['cache_hits']}, cache {st_off['cache']}")
    report(f"cache on: cache hits ({model})", st_on["cache_hits"] > 0 and st_on["cache"] is True,
           f"{st_on['cache_hits']}, cache {st_on['cache']}")
    diff = float(np.mean((on.astype(np.float64) - off) ** 2))
    print(f"# cache on vs off ({model}, 32^3, 64x64): MSE {diff:.3g}, max |difference| {np.abs(on - off).max():.3g}")
    # The cache shades each voxel once for the direction voxel -> camera instead of per ray: for
    # these models only the specular lobe and the normal flip depend on the view, so the images
    # must be far closer to each other than either is to the truth (~1e-2).
    report(f"cache on and off give close images ({model})", diff < 1e-4, f"MSE {diff}")
    # --stats reports the page faults inside the render's clock (issue 15): the render's buffers are
    # touched before it starts, so there are next to none. (tests/unit_render.c checks that bound
    # on a cache large enough for missing pre-faulting to show; here: the field is there and sane.)
    # The render's set-up before its clock (the caches, the shadow ends) is reported apart.
    setup = st_on.get("setup_seconds")
    report(f"--stats setup_seconds: the set-up outside the frame's clock ({model})",
           isinstance(setup, float) and 0 < setup < 5, str(setup))
    faults = st_on.get("render_page_faults")
    report(f"--stats render_page_faults: few faults inside the render's clock ({model})",
           isinstance(faults, (int, float)) and 0 <= faults < 200, str(faults))
    # From a .vox, nothing before the frame used a second thread: the render starts its helper before
    # its clocks (parallel_prestart). Started by the frame's first parallel_for, the helper's stack
    # and thread-local storage (vmesh's 267 kB of views) faulted in inside the clock: 72 faults here,
    # 73 and 1.2 ms of binary's bunny frame (issue 15).
    _, st_fresh = render(SPHERES, f"fresh_{model}", "--vox", path(f"rt_{model}.vox"), *SMALL, "--threads", "2",
                         model=None)
    report(f"render --vox, 2 threads: the helper thread started before the frame's clock ({model})",
           st_fresh["threads"] == 2 and st_fresh["render_page_faults"] < 24, str(st_fresh["render_page_faults"]))
    # The shading cache is sized by the image (tracer/render/shading_cache.h): 4 slots of 24 B a
    # pixel, at most one a voxel. Beside it, with or without it, the shadow memo: these models'
    # opacity does not depend on the direction, and the scene has one directional light with
    # shadows, so each voxel's opacity toward it is remembered (4 B a voxel).
    report(f"--stats cache_bytes: one 24-byte slot a voxel when the image has more pixels ({model})",
           st_on["voxels"] < 4 * 64 * 64 and st_on["cache_bytes"] == (24 + 4) * st_on["voxels"]
           and st_off["cache_bytes"] == 4 * st_off["voxels"], f"{st_on['cache_bytes']} for {st_on['voxels']} voxels, "
           f"{st_off['cache_bytes']} with --no-cache")

    # The C marcher's maps, apart from the caches: the near and far depth per pixel (64 x 64 here)
    # and, for a model that walks past a voxel (alpha, not binary's first hit), the depth slabs'
    # word (in the map and in each thread's part while it is built), and the shadow rays' ends
    # toward the scene's directional light (a few bytes a column across its direction, under 16 kB
    # for this small grid).
    threads = st_on["threads"] if st_on["threads"] else os.cpu_count()
    cell = 2 * 4 + (0 if model == "binary" else 8)
    bounds = cell * 64 * 64 * (1 + threads)
    report(f"--stats map_bytes: the depth bounds' {cell * 64 * 64} B a copy and the shadow ends ({model})",
           bounds < st_on["map_bytes"] < bounds + 16384 and st_on["map_bytes"] == st_off["map_bytes"],
           f"{st_on['map_bytes']} B, {st_off['map_bytes']} B with --no-cache, {threads} threads")

# A grid with more voxels than 4 a pixel: the cache stays at 4 slots a pixel (16x16: 1024). (That the
# image does not depend on the cache's size is tests/unit_render.c's check, with a 16-slot cache.)
small, st_small = render(SPHERES, "cache_small", "--res", "64", "--rays", "16", "--size", "16x16", "--spp", "2")
report("shading cache sized by the image: 1024 slots for a 16x16 image",
       st_small["voxels"] > 1024 and st_small["cache_bytes"] == 1024 * 24 + 4 * st_small["voxels"],
       f"{st_small['cache_bytes']} B for {st_small['voxels']} voxels")

# ---------- (g2) view tiles: vmesh's primary opacity asked once per 4 x 4 pixels ----------
# vmesh asks for view tiles (tracer/render/view_tile.h): the opacity of a voxel's cached answer is
# asked along the direction through the centre of its 4 x 4-pixel lattice cell, not its own. The image
# moves, but far less than its distance to the truth: the ranking of the models cannot change. A
# model that does not ask (alpha) is untouched, and --exact-view / --no-cache turn the tiles off.
TILE = ["--res", "64", "--rays", "32", "--size", "128x128", "--spp", "4"]
tiled, st_tiled = render(SPHERES, "tile_vmesh", *TILE, model="vmesh")
exact, st_exact = render(SPHERES, "tile_vmesh_exact", *TILE, "--exact-view", model="vmesh")
_, st_nocache = render(SPHERES, "tile_vmesh_nocache", *TILE, "--no-cache", model="vmesh")
report("--stats view_tile_pixels: vmesh 4, 0 with --exact-view or --no-cache",
       st_tiled["view_tile_pixels"] == 4 and st_exact["view_tile_pixels"] == 0
       and st_nocache["view_tile_pixels"] == 0,
       f"{st_tiled['view_tile_pixels']}, {st_exact['view_tile_pixels']}, {st_nocache['view_tile_pixels']}")
m_tiled, m_exact = metrics(path("tile_vmesh.exr"), truth128), metrics(path("tile_vmesh_exact.exr"), truth128)
moved = float(np.mean((tiled.astype(np.float64) - exact) ** 2))
print(f"# vmesh spheres 64^3, 128x128: view tiles vs exact direction MSE {moved:.3g}; against the truth "
      f"MSE {m_tiled['mse']:.6f} (exact {m_exact['mse']:.6f}), SSIM {m_tiled['ssim']:.5f} ({m_exact['ssim']:.5f})")
report("view tiles move vmesh's image (they are on)", moved > 0, f"MSE {moved}")
report("view tiles move vmesh's image 1000 times less than its distance to the truth",
       moved < 1e-3 * m_exact["mse"], f"MSE {moved} against {m_exact['mse']}")
report("view tiles: vmesh's MSE and SSIM against the truth within 0.1 % and 1e-4",
       abs(m_tiled["mse"] - m_exact["mse"]) <= 1e-3 * m_exact["mse"] and abs(m_tiled["ssim"] - m_exact["ssim"]) <= 1e-4,
       f"MSE {m_tiled['mse']} / {m_exact['mse']}, SSIM {m_tiled['ssim']} / {m_exact['ssim']}")
a_tiled, st_a = render(SPHERES, "tile_alpha", *TILE, model="alpha")
a_exact, _ = render(SPHERES, "tile_alpha_exact", *TILE, "--exact-view", model="alpha")
report("a model without view tiles: --exact-view changes nothing (alpha)",
       st_a["view_tile_pixels"] == 0 and np.array_equal(a_tiled, a_exact), f"{st_a['view_tile_pixels']}")

# ---------- (g2) the shading cache with the camera among the voxels ----------
# The cache answers a voxel for the direction from its centre to the camera. With the camera 1e-3
# above a plate that fills the view, inside the plate's voxels, that direction is any of them: the
# stability audit saw vicini's plate 76 % see-through and vmesh's dark where --no-cache was right.
# The voxels around the camera's cell are answered per ray, so cache on and off agree.
write_ply(path("near_plate.ply"), [(-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1)], [(0, 1, 2, 3)])
NEAR = write_scene("near_camera", [{"ply": "near_plate.ply", "material": "w", "transform": {"scale": 2}}],
                   [{"type": "directional", "direction": [0.2, 1, 0.1], "irradiance": [3.14159, 3.14159, 3.14159]}],
                   {"position": [0.1, 0.001, 0.1], "look_at": [0.1, -1, 0.1], "up": [0, 0, -1], "fov_deg": 60},
                   materials={"w": {"color": [1, 1, 1]}}, size=(16, 16), background=(0, 0, 1))
for model in ("binary", "alpha", "vmesh", "vicini"):
    on, _ = render(NEAR, f"near_on_{model}", "--res", "32", model=model, stats=False)
    off, _ = render(NEAR, f"near_off_{model}", "--res", "32", "--no-cache", model=model, stats=False)
    gap = float(np.abs(on.reshape(-1, 3).mean(0) - off.reshape(-1, 3).mean(0)).max())
    report(f"camera inside a voxel: cache on and off agree ({model}: mean colours within 0.01)", gap < 0.01,
           f"cache on {on.reshape(-1, 3).mean(0)}, off {off.reshape(-1, 3).mean(0)}")

# ---------- (h) bad command lines ----------
def bad_cli(what, args, words):
    out_dir = path("cli_" + what.replace(" ", "_"))
    os.makedirs(out_dir, exist_ok=True)
    args = [a.replace("OUT", os.path.join(out_dir, "out.exr")) for a in args]
    p = voxlab(*args, check=False)
    err = p.stderr.strip()
    report(f"bad command line fails: {what}", p.returncode != 0, f"rc {p.returncode}")
    report(f"bad command line says why: {what}", all(w in err for w in words), err)
    report(f"bad command line leaves no output: {what}", leftovers(out_dir, "out") == [], str(leftovers(out_dir, "out")))


bad_cli("unknown model", ["render", SPHERES, "--model", "nosuchmodel", "--res", "8", "-o", "OUT"],
        ["nosuchmodel", "unknown model"])
bad_cli("unknown model (bake)", ["bake", SPHERES, "--model", "nosuchmodel", "--res", "8", "-o", "OUT"],
        ["nosuchmodel", "unknown model"])
bad_cli("--res 0", ["render", SPHERES, "--model", "alpha", "--res", "0", "-o", "OUT"], ["--res", "0"])
bad_cli("--res 0 (bake)", ["bake", SPHERES, "--model", "alpha", "--res", "0", "-o", "OUT"], ["--res", "0"])
bad_cli("--res too large", ["render", SPHERES, "--model", "alpha", "--res", "5000", "-o", "OUT"], ["--res", "5000"])
bad_cli("missing -o", ["render", SPHERES, "--model", "alpha", "--res", "8"], ["-o"])
bad_cli("missing -o (bake)", ["bake", SPHERES, "--model", "alpha", "--res", "8"], ["-o"])
bad_cli("--res and --vox together", ["render", SPHERES, "--model", "alpha", "--res", "8", "--vox", good, "-o", "OUT"],
        ["--vox"])
bad_cli("missing scene", ["render", path("nope.json"), "--model", "alpha", "--res", "8", "-o", "OUT"],
        [path("nope.json")])

shutil.rmtree(bad_dir, ignore_errors=True)
finish()
