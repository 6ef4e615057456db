"""`render --backend opencl` (on PoCL in CI) against the C backend.

For every registered model (heitz-neyret by its cone kernel), on spheres and bunny (and a variant
of spheres with specular, depth of field and a point light, which exercises the math library) at
small sizes, the same baked grid is rendered by both backends: the images must agree to 1e-4 per pixel and give the same MSE and SSIM
against the ground truth to 4 significant digits. A model that cannot run on OpenCL must say so
(naming itself, exit status 1) instead of rendering. Also: no OpenCL platform
(OCL_ICD_VENDORS=/nonexistent) and a kernel that fails to build (the test hook
VOXLAB_OPENCL_BREAK_KERNEL=1 appends a syntax error to the program) are clear errors, the latter
with the build log; the compile is cached (POCL_CACHE_DIR) and reported apart from the render time,
and so is the set-up (the buffers, their upload, the caches' clearing), as the C backend's. The
GPU's wide launch (VOXLAB_OPENCL_WIDE=1) renders the same images bit for bit on PoCL; the device is
picked by VOXLAB_OPENCL_DEVICE, or refused with the list of devices; the directional light's
opacity memo answers shadow steps on both backends alike (shadow_memo_hits).
"""
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report, voxlab  # noqa: E402

SIZE = "64x48"
RES = 64


def run(*args, env=None):
    e = dict(os.environ)
    e.update(env or {})
    return subprocess.run([VOXLAB, *map(str, args)], capture_output=True, text=True, env=e)


def models():
    return [line.split()[0] for line in voxlab("models").stdout.splitlines() if line.strip()]


def fx_scene():
    """spheres with every effect the voxel shading reads: specular lobe, thin lens, a point light."""
    with open(os.path.join(REPO, "scenes", "spheres.json")) as f:
        s = json.load(f)
    s["name"] = "spheres-fx"
    s["effects"] = ["shadows", "textures", "specular", "dof"]
    s["camera"]["aperture"] = 0.15
    s["camera"]["focus_distance"] = 10.0
    s["lights"].append({"type": "point", "position": [1.0, 3.0, 2.0], "intensity": [8, 8, 8]})
    path = os.path.join(TMP, "spheres_fx.json")
    with open(path, "w") as f:
        json.dump(s, f)
    return path


def metrics(image, truth):
    return json.loads(voxlab("compare", image, truth, "--json").stdout)


def same_4_digits(a, b):
    if a is None or b is None:
        return a == b
    # Equal when rounded to 4 significant digits; a pair straddling a rounding boundary is accepted
    # when it is within half a unit of the 4th digit.
    return f"{a:.4g}" == f"{b:.4g}" or abs(a - b) <= 5e-5 * max(abs(a), abs(b))


scenes = {
    "spheres": os.path.join(REPO, "scenes", "spheres.json"),
    "bunny": os.path.join(REPO, "scenes", "bunny.json"),
    "spheres-fx": fx_scene(),
}
names = models()
report("models_listed", len(names) >= 2, f"{names}")

# Ground truth once per scene.
truth = {}
for sname, spath in scenes.items():
    truth[sname] = os.path.join(TMP, f"truth_{sname}.exr")
    voxlab("truth", spath, "--spp", "64", "--size", SIZE, "-o", truth[sname])

runnable = []
for model in names:
    for sname, spath in scenes.items():
        vox = os.path.join(TMP, f"{sname}_{model}.vox")
        voxlab("bake", spath, "--model", model, "--res", RES, "--rays", 64, "-o", vox)
        out = {b: os.path.join(TMP, f"{sname}_{model}_{b}.exr") for b in ("c", "opencl")}
        stats = os.path.join(TMP, f"{sname}_{model}_opencl.json")
        c_stats = os.path.join(TMP, f"{sname}_{model}_c.json")
        voxlab("render", spath, "--vox", vox, "--size", SIZE, "-o", out["c"], "--stats", c_stats)
        w0 = time.monotonic()
        p = run("render", spath, "--vox", vox, "--size", SIZE, "--backend", "opencl", "-o", out["opencl"],
                "--stats", stats)
        wall = time.monotonic() - w0
        if p.returncode != 0:
            # Allowed only as a clear refusal: the model named, OpenCL said, no image left behind.
            clear = (p.returncode == 1 and f"model {model} cannot run on OpenCL" in p.stderr
                     and not os.path.exists(out["opencl"]))
            report(f"{model}_{sname}_refused_clearly", clear, f"rc {p.returncode}: {p.stderr.strip()}")
            break
        if model not in runnable:
            runnable.append(model)
        a, b = read_image(out["c"]), read_image(out["opencl"])
        diff = float(np.abs(a - b).max())
        print(f"# {model} {sname}: max |opencl - c| = {diff:.3g}")
        report(f"{model}_{sname}_per_pixel_agreement", diff <= 1e-4, f"max difference {diff}")
        mc, mo = metrics(out["c"], truth[sname]), metrics(out["opencl"], truth[sname])
        print(f"# {model} {sname}: C mse {mc['mse']:.6g} ssim {mc['ssim']:.6g}; "
              f"OpenCL mse {mo['mse']:.6g} ssim {mo['ssim']:.6g}")
        report(f"{model}_{sname}_metrics_4_digits",
               same_4_digits(mc["mse"], mo["mse"]) and same_4_digits(mc["ssim"], mo["ssim"]), f"C {mc}, OpenCL {mo}")
        with open(stats) as f:
            st = json.load(f)
        with open(c_stats) as f:
            cst = json.load(f)
        # 4 rays per pixel, or one cone per pixel for a cone-marching model: as many as the C backend.
        report(f"{model}_{sname}_stats", st.get("backend") == "opencl" and st.get("opencl_compile_seconds", -1) >= 0
               and st["seconds"] > 0 and st["rays"] == cst["rays"] and st["rays"] in (64 * 48, 64 * 48 * 4)
               and st["voxel_visits"] > 0, f"{st}")
        # The directional light's opacity memo (shadow steps answered without asking the model) runs
        # on both backends alike: every scene here has a sun and shadows, which every voxel-marching
        # model's shadow rays use it for (the cone marcher has its own light cache); a race between two
        # threads or work-items over one slot moves a few hits, and so does the C backend's shading
        # cache (a hash table whose collisions, raced by the threads, decide how many voxels are
        # shaded twice, each with its shadow rays): the counts agree within a quarter.
        hc, ho = cst.get("shadow_memo_hits"), st.get("shadow_memo_hits")
        expect = model != "heitz-neyret"
        report(f"{model}_{sname}_shadow_memo_on_both", isinstance(hc, int) and isinstance(ho, int)
               and (hc > 0) == expect and (ho > 0) == expect and (not expect or 0.8 <= ho / hc <= 1.25),
               f"C {hc}, OpenCL {ho} hits (used: {expect})")
        # The set-up (buffers, uploads, clears) is reported apart from `seconds`, as the C backend's
        # caches and maps are: both numbers measured, and with the compile within the process's time.
        setup = st.get("setup_seconds")
        report(f"{model}_{sname}_setup_apart", isinstance(setup, float) and setup > 0
               and isinstance(cst.get("setup_seconds"), float)
               and setup + st["seconds"] + st["opencl_compile_seconds"] <= wall
               and st["opencl_kernel_seconds"] <= st["seconds"],
               f"setup {setup}, seconds {st['seconds']}, compile {st['opencl_compile_seconds']}, "
               f"kernel {st['opencl_kernel_seconds']}, process {wall:.3f} s")
report("binary_and_alpha_run_on_opencl", "binary" in runnable and "alpha" in runnable, f"runnable: {runnable}")
report("heitz_neyret_runs_on_opencl", "heitz-neyret" in runnable, f"runnable: {runnable}")

# The options that change the tracer's work: no cache, no shadow skip, another spp and seed.
if "alpha" in runnable:
    vox = os.path.join(TMP, "spheres-fx_alpha.vox")
    for opts in (["--no-cache"], ["--no-shadow-skip"], ["--spp", "7", "--seed", "5"]):
        tag = "_".join(o.strip("-") for o in opts)
        outs = []
        for backend in ("c", "opencl"):
            o = os.path.join(TMP, f"opt_{tag}_{backend}.exr")
            voxlab("render", scenes["spheres-fx"], "--vox", vox, "--size", SIZE, "--backend", backend, *opts, "-o", o)
            outs.append(read_image(o))
        diff = float(np.abs(outs[0] - outs[1]).max())
        report(f"alpha_spheres-fx_{tag}_agreement", diff <= 1e-4, f"max difference {diff}")

# heitz-neyret (cone marching): without the light cache too; and the image is the same for any
# number of PoCL threads and on every run (the light cache is filled in whatever order work-items run).
if "heitz-neyret" in runnable:
    vox = os.path.join(TMP, "spheres-fx_heitz-neyret.vox")
    outs = []
    for backend in ("c", "opencl"):
        o = os.path.join(TMP, f"hn_nocache_{backend}.exr")
        voxlab("render", scenes["spheres-fx"], "--vox", vox, "--size", SIZE, "--backend", backend, "--no-cache", "-o", o)
        outs.append(read_image(o))
    diff = float(np.abs(outs[0] - outs[1]).max())
    report("heitz-neyret_spheres-fx_no-cache_agreement", diff <= 1e-4, f"max difference {diff}")
    vox = os.path.join(TMP, "bunny_heitz-neyret.vox")
    runs = []
    for i, threads in enumerate((1, 2, 2)):
        o = os.path.join(TMP, f"hn_det_{i}.exr")
        voxlab("render", scenes["bunny"], "--vox", vox, "--size", SIZE, "--backend", "opencl", "--threads", threads,
               "-o", o)
        runs.append(read_image(o))
    report("heitz-neyret_opencl_deterministic", all(np.array_equal(runs[0], r) for r in runs[1:]),
           "runs with 1 and 2 threads differ")

# The GPU's launch (VOXLAB_OPENCL_WIDE=1: 16 work-groups per compute unit, one pixel at a time)
# renders the same image as the CPU's tiles, bit for bit, for every model; --stats says which ran.
for model in runnable:
    vox = os.path.join(TMP, f"bunny_{model}.vox")
    imgs, wide = [], []
    for flag in ("0", "1"):
        o = os.path.join(TMP, f"launch_{model}_{flag}.exr")
        st = os.path.join(TMP, f"launch_{model}_{flag}.json")
        p = run("render", scenes["bunny"], "--vox", vox, "--size", SIZE, "--backend", "opencl", "-o", o,
                "--stats", st, env={"VOXLAB_OPENCL_WIDE": flag})
        if p.returncode != 0:
            imgs.append(None)
            wide.append(p.stderr.strip())
            continue
        imgs.append(read_image(o))
        with open(st) as f:
            wide.append(json.load(f).get("opencl_wide_launch"))
    same = imgs[0] is not None and imgs[1] is not None and np.array_equal(imgs[0], imgs[1])
    report(f"{model}_wide_launch_same_image", same and wide == [False, True], f"launches {wide}, same image {same}")

# The device: VOXLAB_OPENCL_DEVICE picks one by kind or by a part of its name (PoCL's is a CPU); a
# request nothing matches is a clear error naming the devices there are.
vox = os.path.join(TMP, "spheres_binary.vox")
bad = os.path.join(TMP, "bad.exr")
st = os.path.join(TMP, "device_cpu.json")
p = run("render", scenes["spheres"], "--vox", vox, "--size", SIZE, "--backend", "opencl", "-o", bad, "--stats", st,
        env={"VOXLAB_OPENCL_DEVICE": "cpu"})
ok = p.returncode == 0 and os.path.exists(bad)
if ok:
    with open(st) as f:
        ok = json.load(f).get("opencl_wide_launch") is False
    os.remove(bad)
report("device_cpu_requested", ok, f"rc {p.returncode}: {p.stderr.strip()}")
p = run("render", scenes["spheres"], "--vox", vox, "--size", SIZE, "--backend", "opencl", "-o", bad,
        env={"VOXLAB_OPENCL_DEVICE": "no-such-device"})
report("device_not_found_is_a_clear_error", p.returncode == 1 and "VOXLAB_OPENCL_DEVICE=no-such-device" in p.stderr
       and "the devices:" in p.stderr and not os.path.exists(bad), f"rc {p.returncode}: {p.stderr.strip()}")

# Failures are messages, not crashes.
p = run("render", scenes["spheres"], "--vox", vox, "--size", SIZE, "--backend", "opencl", "-o", bad,
        env={"OCL_ICD_VENDORS": "/nonexistent"})
report("no_platform_is_a_clear_error", p.returncode == 1 and "no OpenCL platform" in p.stderr
       and not os.path.exists(bad), f"rc {p.returncode}: {p.stderr.strip()}")
p = run("render", scenes["spheres"], "--vox", vox, "--size", SIZE, "--backend", "opencl", "-o", bad,
        env={"VOXLAB_OPENCL_BREAK_KERNEL": "1"})
report("kernel_build_failure_shows_the_log", p.returncode == 1 and "failed to build" in p.stderr
       and "build log" in p.stderr and "VOXLAB_OPENCL_BREAK_KERNEL" in p.stderr and not os.path.exists(bad),
       f"rc {p.returncode}: {p.stderr.strip()}")
p = run("render", scenes["spheres"], "--vox", vox, "--backend", "cuda", "-o", bad)
report("unknown_backend_rejected", p.returncode == 1 and "--backend cuda" in p.stderr, p.stderr.strip())

# The kernel cache: a fresh POCL_CACHE_DIR fills on the first run, and the second run compiles less.
cache = os.path.join(TMP, "pocl-cache")
shutil.rmtree(cache, ignore_errors=True)
secs = []
for i in range(2):
    st = os.path.join(TMP, f"cache_{i}.json")
    p = run("render", scenes["spheres"], "--vox", vox, "--size", SIZE, "--backend", "opencl", "-o", bad,
            "--stats", st, env={"POCL_CACHE_DIR": cache})
    if p.returncode != 0:
        secs.append(None)
        continue
    with open(st) as f:
        secs.append(json.load(f)["opencl_compile_seconds"])
print(f"# compile seconds: cold {secs[0]}, cached {secs[1]}")
report("kernel_cache_filled", os.path.isdir(cache) and len(os.listdir(cache)) > 0, f"{cache}")
report("kernel_cache_reused", None not in secs and secs[1] < secs[0] / 3, f"compile seconds cold, warm: {secs}")

finish()
