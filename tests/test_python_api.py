"""The Python package experiments/voxlab/ (through build/libvoxlab.so, tracer/api/) against the CLI:

1. render, truth and bake give the CLI's pixels and .vox bytes exactly, and the same --stats keys
   and (timings and memory aside) values; compare() is `voxlab compare --json`;
2. scenes given as dicts (relative mesh paths against base_dir) render as their files do;
3. a failure raises voxlab.VoxlabError with the message the CLI prints;
4. truth, bake, render and compare run in-process: no subprocess is started, no file written;
5. voxlab.experiment({...}) runs a declaration given as a dict and returns its rows as a DataFrame.

Under `make test-asan` the library is AddressSanitizer's: the test runs itself again with the ASan
runtime preloaded (it must come first in a process whose python3 was not built with it)."""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report, write_ply  # noqa: E402
from testlib import voxlab as cli  # noqa: E402  (the name voxlab is the package's here)

BUILD = os.environ.get("BUILD", "build")
LIB = os.path.join(REPO, BUILD, "libvoxlab.so")
os.environ["VOXLAB_LIB"] = LIB
if "asan" in BUILD and "libasan" not in os.environ.get("LD_PRELOAD", ""):
    runtime = subprocess.run(["gcc", "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    env = dict(os.environ, LD_PRELOAD=runtime,
               # Python's own allocations are not this test's leaks.
               ASAN_OPTIONS=os.environ.get("ASAN_OPTIONS", "") + ":detect_leaks=0")
    os.execve(sys.executable, [sys.executable, *sys.argv], env)

sys.path.insert(0, os.path.join(REPO, "experiments"))
import numpy as np  # noqa: E402

import voxlab  # noqa: E402

SPHERES = os.path.join(REPO, "scenes", "spheres.json")
# Timings and memory differ from run to run; everything else in --stats must match.
# bvh_bytes is Embree's allocator total: its parallel builder takes blocks per worker
# thread, so it depends on how the build was scheduled (CI saw 1,310,332 against 1,283,324).
VARYING = ("seconds", "peak_rss_bytes", "bake_rays_per_second", "bvh_bytes", "page_faults")


def same_stats(name, api, cli):
    report(f"{name}: stats have --stats' keys", set(api) == set(cli), str(sorted(set(api) ^ set(cli))))
    diff = {k: (api.get(k), cli[k]) for k in cli if not k.endswith(VARYING) and api.get(k) != cli[k]}
    report(f"{name}: stats have --stats' values (timings and memory aside)", not diff, str(diff))


def cli_error(*args):
    """The message `voxlab CMD ...` prints after "voxlab CMD: "."""
    p = cli(*args, check=False)
    line = p.stderr.strip().splitlines()[-1] if p.stderr.strip() else ""
    return p.returncode, line.split(": ", 1)[1] if ": " in line else line


def raises(fn):
    try:
        fn()
    except voxlab.VoxlabError as e:
        return str(e)
    return None


def bit_for_bit():
    out, st = os.path.join(TMP, "cli_render.exr"), os.path.join(TMP, "cli_render.json")
    # One thread: the cache's counters (cache_hits, model_evals, shadow_rays) depend on which thread
    # meets a voxel first; the pixels do not (and are compared below at every core as well).
    cli("render", SPHERES, "--model", "alpha", "--res", 32, "--size", "48x32", "--spp", 4, "--threads", 1,
        "-o", out, "--stats", st)
    img, stats = voxlab.render(SPHERES, model="alpha", res=32, size=(48, 32), spp=4, seed=1, threads=1)
    want = read_image(out)
    report("render: a float32 (height, width, 3) array", img.dtype == np.float32 and img.shape == (32, 48, 3),
           f"{img.dtype} {img.shape}")
    report("render: the CLI's pixels bit for bit", img.shape == want.shape and img.tobytes() == want.tobytes(),
           f"max difference {np.abs(img - want).max() if img.shape == want.shape else 'shape'}")
    with open(st) as f:
        same_stats("render", stats, json.load(f))
    every_core, _ = voxlab.render(SPHERES, model="alpha", res=32, size=(48, 32), spp=4, seed=1)
    report("render at every core: the same pixels", every_core.tobytes() == img.tobytes(), "")

    out, st = os.path.join(TMP, "cli_truth.exr"), os.path.join(TMP, "cli_truth.json")
    cli("truth", SPHERES, "--size", "40x24", "--spp", 16, "--seed", 3, "-o", out, "--stats", st)
    ref, tstats = voxlab.truth(SPHERES, size=(40, 24), spp=16, seed=3)
    report("truth: the CLI's pixels bit for bit", ref.tobytes() == read_image(out).tobytes(), "")
    with open(st) as f:
        same_stats("truth", tstats, json.load(f))

    vox, st = os.path.join(TMP, "cli.vox"), os.path.join(TMP, "cli_bake.json")
    cli("bake", SPHERES, "--model", "vmesh", "--res", 16, "--rays", 40, "--seed", 5, "-o", vox, "--stats", st)
    api_vox = os.path.join(TMP, "api.vox")
    baked, bstats = voxlab.bake(SPHERES, "vmesh", 16, rays=40, seed=5, out=api_vox)
    with open(vox, "rb") as a, open(api_vox, "rb") as b:
        report("bake: the .vox file `voxlab bake` writes, byte for byte", a.read() == b.read(), "")
    with open(st) as f:
        same_stats("bake", bstats, json.load(f))

    # A bake kept in memory, a .vox path and `render --vox` all give one image.
    out = os.path.join(TMP, "cli_vox.exr")
    cli("render", SPHERES, "--vox", vox, "--size", "24x16", "--spp", 2, "--seed", 5, "-o", out)
    a, _ = voxlab.render(SPHERES, vox=baked, size=(24, 16), spp=2, seed=5)
    b, vstats = voxlab.render(SPHERES, vox=vox, size=(24, 16), spp=2, seed=5)
    report("render of a Bake and of a .vox path: `render --vox`'s pixels",
           a.tobytes() == b.tobytes() == read_image(out).tobytes(), "")
    report("render of a .vox: bake_seconds None as in --stats", vstats["bake_seconds"] is None, str(vstats))

    # compare() is `voxlab compare --json`, from arrays or paths.
    tpath = os.path.join(TMP, "cli_truth48.exr")
    cli("truth", SPHERES, "--size", "48x32", "--spp", 16, "-o", tpath)
    want = json.loads(cli("compare", tpath, os.path.join(TMP, "cli_render.exr"), "--json").stdout)
    truth48, _ = voxlab.truth(SPHERES, size=(48, 32), spp=16)
    got = voxlab.compare(truth48, img)
    no_prov = {k: v for k, v in want.items() if k != "provenance"}
    report("compare(arrays) == `voxlab compare --json` (arrays carry no provenance)", got == no_prov,
           f"{got} vs {want}")
    got = voxlab.compare(tpath, os.path.join(TMP, "cli_render.exr"))
    report("compare(paths) == `voxlab compare --json` (OpenImageIO plugin found beside the library)",
           got == want, f"{got} vs {want}")
    return img


def dict_scenes(img):
    with open(SPHERES) as f:
        d = json.load(f)
    a, _ = voxlab.render(d, model="alpha", res=32, size=(48, 32), spp=4, seed=1)
    report("a scene dict renders as its file", a.tobytes() == img.tobytes(), "")
    # A mesh by a relative path: resolved against base_dir, as against a scene file's folder.
    mesh_dir = os.path.join(TMP, "meshes")
    os.makedirs(mesh_dir, exist_ok=True)
    write_ply(os.path.join(mesh_dir, "tri.ply"), [(-1, 0, -1), (1, 0, -1), (0, 1, 0), (0, 0, 1)],
              [(0, 1, 2), (1, 3, 2), (3, 0, 2)])
    scene = {"name": "tri", "size": [20, 16], "background": [0.1, 0.2, 0.3],
             "camera": {"position": [0, 1, 4], "look_at": [0, 0.3, 0], "up": [0, 1, 0], "fov_deg": 40},
             "lights": [{"type": "directional", "direction": [0.3, 1, 0.5], "irradiance": [2, 2, 2]}],
             "materials": {"m": {"color": [0.7, 0.6, 0.5], "double_sided": True}},
             "objects": [{"ply": "meshes/tri.ply", "material": "m"}]}
    path = os.path.join(TMP, "tri.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    a, _ = voxlab.truth(scene, spp=4, base_dir=TMP)
    b, _ = voxlab.truth(path, spp=4)
    report("a scene dict's relative mesh path resolves against base_dir", a.tobytes() == b.tobytes(), "")
    loaded = voxlab.Scene(scene, base_dir=TMP)
    c, _ = voxlab.render(loaded, model="binary", res=8, spp=1)
    d2, _ = voxlab.render(path, model="binary", res=8, spp=1)
    report("a Scene loaded once renders as its file", c.tobytes() == d2.tobytes() and loaded.size == (20, 16), "")
    msg = raises(lambda: voxlab.truth(dict(scene, objects=[{"ply": "meshes/none.ply", "material": "m"}]),
                                      spp=1, base_dir=TMP))
    report("a scene dict's missing mesh: an error naming the resolved path",
           msg is not None and os.path.join(TMP, "meshes/none.ply") in msg, str(msg))


def errors():
    rc, want = cli_error("render", SPHERES, "--model", "nope", "--res", 8, "-o", os.path.join(TMP, "e.exr"))
    msg = raises(lambda: voxlab.render(SPHERES, model="nope", res=8))
    report("unknown model: VoxlabError with the C message",
           msg is not None and "unknown model (see `voxlab models`)" in msg and rc == 1, f"{msg!r} vs {want!r}")
    bad = os.path.join(TMP, "bad_scene.json")
    with open(SPHERES) as f:
        d = json.load(f)
    d["camera"]["fov_deg"] = "wide"
    with open(bad, "w") as f:
        json.dump(d, f)
    rc, want = cli_error("truth", bad, "--spp", 1, "-o", os.path.join(TMP, "e.exr"))
    msg = raises(lambda: voxlab.truth(bad, spp=1))
    report("bad scene field: VoxlabError with the CLI's message", rc == 1 and msg == want and "fov_deg" in msg,
           f"{msg!r} vs {want!r}")
    msg = raises(lambda: voxlab.truth(d, spp=1))
    report("bad scene field in a dict: the message names the field", msg is not None and "fov_deg" in msg
           and "<scene dict>" in msg, str(msg))
    rc, want = cli_error("bake", SPHERES, "--model", "alpha", "--res", 8, "--param", "nope=1", "-o",
                         os.path.join(TMP, "e.vox"))
    msg = raises(lambda: voxlab.bake(SPHERES, "alpha", 8, params={"nope": 1}))
    report("unknown model parameter: the CLI's message", rc == 1 and msg == want, f"{msg!r} vs {want!r}")
    msg = raises(lambda: voxlab.compare(os.path.join(TMP, "missing.exr"), np.zeros((2, 2, 3), np.float32)))
    report("compare of a missing file: the C message naming it", msg is not None and "missing.exr" in msg, str(msg))
    other = voxlab.Scene(os.path.join(TMP, "tri.json"))
    baked, _ = voxlab.bake(SPHERES, "binary", 8)
    msg = raises(lambda: voxlab.render(other, vox=baked))
    report("a bake rendered with another scene is refused", msg is not None and "another scene" in msg, str(msg))


def in_process():
    """No subprocess and no file written by truth, bake, render and compare."""
    import subprocess as sp

    calls = []
    saved = sp.Popen, os.fork, os.posix_spawn

    def refuse(*a, **k):
        calls.append(a[:1])
        raise AssertionError("a process was started")

    sp.Popen, os.fork, os.posix_spawn = refuse, refuse, refuse
    before = set(os.listdir(TMP))
    try:
        ref, _ = voxlab.truth(SPHERES, size=(16, 12), spp=4)
        b, _ = voxlab.bake(SPHERES, "heitz-neyret", 8)
        img, _ = voxlab.render(SPHERES, vox=b, size=(16, 12), spp=1)
        m = voxlab.compare(ref, img)
        ok = m["width"] == 16 and 0 < m["mse"]
    finally:
        sp.Popen, os.fork, os.posix_spawn = saved
    report("truth, bake, render, compare: no process started", ok and not calls, str(calls))
    report("truth, bake, render, compare: no file written", set(os.listdir(TMP)) == before,
           str(set(os.listdir(TMP)) ^ before))


def experiment():
    results = os.path.join(TMP, "results")
    decl = {"name": "pyapi", "truth_spp": 16, "repeats": 1, "scenes": ["spheres"],
            "runs": [{"models": ["binary", "alpha"], "res": [16], "size": "res", "spp": [2], "rays": [40]}]}
    df = voxlab.experiment(decl, results=results, voxlab=VOXLAB)
    report("experiment(dict): a DataFrame, one row per configuration, all ok",
           len(df) == 2 and list(df["status"]) == ["ok", "ok"] and set(df["model"]) == {"binary", "alpha"},
           df.to_string()[:1500])
    metrics = voxlab_metrics()
    report("experiment(dict): the metric columns `voxlab compare --list-metrics` names",
           all(m in df.columns and df[m].notna().all() for m in metrics), str(list(df.columns)))
    report("experiment(dict): rows.csv written as by sweep.py",
           os.path.exists(os.path.join(results, "pyapi", "rows.csv")) and df.attrs["meta"]["experiment"] == "pyapi",
           "")
    bad = dict(decl, runs=[{"models": ["binary"], "res": ["x"]}])
    msg = raises(lambda: voxlab.experiment(bad, results=results, voxlab=VOXLAB))
    report("experiment(bad dict): VoxlabError naming the field", msg is not None and "runs[0].res" in msg, str(msg))


def voxlab_metrics():
    return voxlab_cli_lines("compare", "--list-metrics")


def voxlab_cli_lines(*args):
    return [x for x in cli(*args).stdout.split() if x]


def compare_first():
    """compare() of two arrays as a process's first call into the library: it used the library
    before anything had opened it (AttributeError: 'NoneType' object has no attribute
    'vxapi_compare'), as only the paths' branch loaded it. A fresh interpreter, since this one has
    loaded it already."""
    code = ("import json, numpy as np, voxlab\n"
            "a = np.linspace(0, 1, 16 * 16 * 3, dtype=np.float32).reshape(16, 16, 3)\n"
            "print(json.dumps(voxlab.compare(a, a * 0.5)))\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=os.path.join(REPO, "experiments")))
    got = json.loads(p.stdout) if p.returncode == 0 else {}
    a = np.linspace(0, 1, 16 * 16 * 3, dtype=np.float32).reshape(16, 16, 3).astype(np.float64)
    want = float(np.mean((a - a * 0.5) ** 2))
    report("compare(arrays) as the first call of a process", p.returncode == 0 and abs(got.get("mse", -1) - want)
           <= 1e-12, p.stderr.strip()[-300:])


def main():
    if not os.path.exists(LIB):
        report("build/libvoxlab.so exists (make pylib)", False, LIB)
        return
    compare_first()
    report("models(): `voxlab models`' names", voxlab.models() == [
        line.split()[0] for line in cli("models").stdout.splitlines() if line.strip()], "")
    img = bit_for_bit()
    dict_scenes(img)
    errors()
    in_process()
    experiment()


if __name__ == "__main__":
    main()
    finish()
