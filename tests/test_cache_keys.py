"""Cache keys follow each job's code path (experiments/code_keys.py), checked two ways.

1. Against the linker: the units a code path leaves out (VOXEL_ONLY for the truth, TRUTH_ONLY for
   model jobs, other models' files for a model) define no symbol that a unit it keeps refers to
   (`nm` on the objects `make` built). main.c, the command dispatcher, refers to every command, and
   another command's cmd_*.c is kept only for shared helpers: their references are not followed.
2. On a sweep, in a scratch copy of the sources (the voxlab binary copied beside them, so no rebuild):
   adding a model reruns nothing of the others; editing a model's source reruns exactly that model's
   bake, render and compare, and says which file invalidated them; editing the truth renderer reruns
   the truth and the compares, not the bakes and renders; editing the tracer's voxel code reruns
   every model job but not the truth; --force reruns everything; a binary built with other flags
   (its `voxlab --version` build line) reruns everything, and the first build's entries stay valid
   for it; and sources newer than the binary are refused."""
import json
import os
import re
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, report  # noqa: E402

sys.path.insert(0, os.path.join(REPO, "experiments"))
import code_keys  # noqa: E402

BUILD = os.path.join(REPO, os.environ.get("BUILD", "build"))
PY = "/usr/bin/python3"


def symbols(obj, defined):
    p = subprocess.run(["nm", "--defined-only" if defined else "--undefined-only", "-g", obj],
                       capture_output=True, text=True)
    return {line.split()[-1] for line in p.stdout.splitlines() if line.strip()}


def obj_of(src):
    return os.path.join(BUILD, src + ".o")


def linker_checks():
    units = [f for f in code_keys.tracer_sources() | {os.path.relpath(p, REPO) for p in
                                                         __import__("glob").glob(os.path.join(REPO, "models", "**", "*.c"),
                                                                                  recursive=True)}
             if f.endswith((".c", ".cpp")) and os.path.isfile(obj_of(f))]
    if not units:
        report("objects built (make)", False, f"no objects under {BUILD}")
        return
    defined = {u: symbols(obj_of(u), True) for u in units}
    needed = {u: symbols(obj_of(u), False) for u in units}

    def leaks(kept, left_out, own_command):
        # main.c dispatches to every command, and another command's cmd_*.c is kept only for the
        # helpers it shares (stats, peak RSS): a job runs its own command alone, so their references
        # are not followed (a check at the granularity of units, not functions).
        skip = {k for k in kept if k == "tracer/cli/main.c" or (k.startswith("tracer/cli/cmd_") and k not in own_command)}
        return sorted((k, l, s) for k in kept if k not in skip for l in left_out for s in needed[k] & defined[l])

    truth = set(code_keys.code_files("truth"))
    kept, out = [u for u in units if u in truth], [u for u in units if u not in truth]
    bad = leaks(kept, out, {"tracer/cli/cmd_truth.c"})
    report("truth: the units its key leaves out define nothing its units use", kept and not bad, str(bad[:5]))
    for m in ("binary", "alpha", "vmesh", "heitz-neyret"):
        files = set(code_keys.code_files("render", m))
        kept, out = [u for u in units if u in files], [u for u in units if u not in files and u != "models/registry.c"]
        bad = leaks(kept, out, {"tracer/cli/cmd_bake.c", "tracer/cli/cmd_render.c", "tracer/cli/cmd_compare.c"})
        report(f"{m}: the units its key leaves out define nothing its units use",
               any(k.startswith("models/") for k in kept) and not bad, str(bad[:5]))
    report("a model's key holds no other model's file and not the registry",
           "models/vmesh/vmesh.c" not in code_keys.code_files("render", "alpha") and
           "models/registry.c" not in code_keys.code_files("render", "alpha") and
           "models/alpha/alpha.c" in code_keys.code_files("bake", "alpha"), "")
    truth = code_keys.code_files("truth")
    report("the truth's key holds models/model.h (its VX_MAX_LIGHTS) and no model's own file",
           "models/model.h" in truth and not [f for f in truth if f.startswith("models/") and f != "models/model.h"],
           str([f for f in truth if f.startswith("models/")]))
    report("Embree's version is in the truth's, the bakes' and the renders' keys, not the compares'",
           all("embree" in code_keys.code_key(k, m)[2] for k, m in (("truth", None), ("bake", "alpha"),
                                                                   ("render", "alpha"))) and
           "embree" not in code_keys.code_key("compare")[2], "")
    report("the truth's key holds no models/ file but model.h, and no voxel unit",
           not any(f.startswith("models/") and f != "models/model.h" for f in truth) and
           "tracer/render/render.c" not in truth and "tracer/truth/truth.c" in truth, "")


def scratch():
    root = os.path.join(TMP, "repo")
    shutil.rmtree(root, ignore_errors=True)
    os.makedirs(root)
    for d in ("experiments", "tracer", "models"):
        shutil.copytree(os.path.join(REPO, d), os.path.join(root, d),
                        ignore=shutil.ignore_patterns("__pycache__"))
    os.makedirs(os.path.join(root, "scenes"))
    shutil.copytree(os.path.join(REPO, "scenes", "generators"), os.path.join(root, "scenes", "generators"))
    shutil.copy(os.path.join(REPO, "scenes", "spheres.json"), os.path.join(root, "scenes"))
    shutil.copy(os.path.join(REPO, "Makefile"), root)
    os.makedirs(os.path.join(root, "build"))
    for f in ("voxlab", "libvoxlab_oiio.so"):
        if os.path.exists(os.path.join(os.path.dirname(VOXLAB), f)):
            shutil.copy2(os.path.join(os.path.dirname(VOXLAB), f), os.path.join(root, "build", f))
    with open(os.path.join(root, "tiny.json"), "w") as f:
        json.dump({"name": "tiny", "truth_spp": 16, "scenes": ["spheres"], "repeats": 1,
                   "runs": [{"models": ["binary", "alpha"], "res": [16], "size": "res", "spp": [4]}]}, f)
    return root


def edit(root, rel, text="\n/* an edit */\n"):
    with open(os.path.join(root, rel), "a") as f:
        f.write(text)


def rebuilt(root):
    """What `make` would do here as far as the keys care: the binary is newer than the sources."""
    now = time.time() + 2
    os.utime(os.path.join(root, "build", "voxlab"), (now, now))


def sweep(root, *extra):
    p = subprocess.run([PY, os.path.join(root, "experiments", "sweep.py"), os.path.join(root, "tiny.json"),
                        "--results", os.path.join(root, "results"), "--voxlab", os.path.join(root, "build", "voxlab"),
                        *extra], capture_output=True, text=True)
    ran = sorted(re.findall(r"\] [^|]*\| (truth|bake|render|compare) (\S+)", p.stderr))
    return p, ran


def sweep_checks():
    root = scratch()
    p, ran = sweep(root)
    report("scratch sweep runs all 7 jobs", p.returncode == 0 and len(ran) == 7, p.stderr[-1500:])
    if p.returncode != 0:
        return
    # Adding a model: its folder and a registry line. Nothing already computed reruns.
    os.makedirs(os.path.join(root, "models", "newmodel"))
    shutil.copy(os.path.join(root, "models", "alpha", "alpha.c"), os.path.join(root, "models", "newmodel", "newmodel.c"))
    edit(root, "models/registry.def", "VX_MODEL(newmodel)\n")
    rebuilt(root)
    p, ran = sweep(root)
    report("adding a model reruns no other model's job and no truth", p.returncode == 0 and ran == [] and
           "0 job(s) to run" in p.stderr, f"ran {ran}\n{p.stderr[-800:]}")
    edit(root, "models/alpha/alpha.c")
    rebuilt(root)
    p, ran = sweep(root)
    report("editing alpha.c reruns alpha's bake, render and compare only",
           [k for k, _ in ran] == ["bake", "compare", "render"] and all("alpha" in lbl for _, lbl in ran),
           f"ran {ran}")
    report("the invalidation is reported with the file that changed",
           re.search(r"invalidated 1 cached bake job\(s\) \(spheres-alpha[^)]*\): models/alpha/alpha.c changed", p.stderr)
           is not None, p.stderr[-1200:])
    with open(os.path.join(root, "results", "tiny", "rows.json")) as f:
        doc = json.load(f)
    inv = doc["meta"]["invalidated"]
    shared = {r["model"]: r.get("bake_shared") for r in doc["rows"] if r["kind"] == "model"}
    report("alpha's bake, rerun alone, is marked as its own; binary's is still the shared pass's",
           shared == {"alpha": 0, "binary": 1}, str(shared))
    sys.path.insert(0, os.path.join(root, "experiments"))
    import table1  # noqa: E402
    from voxlab_exp.schema import load_declaration  # noqa: E402
    t1_out = os.path.join(root, "results", "tiny-table")
    os.makedirs(t1_out, exist_ok=True)
    table1.build(doc["meta"], doc["rows"], load_declaration(os.path.join(root, "tiny.json")), t1_out)
    with open(os.path.join(t1_out, "table2.md")) as f:
        md = f.read()
    alpha_cells = [line for line in md.splitlines() if line.startswith("| spheres |")]
    report("Table 2 marks the bake of its own with a dagger and says what it means",
           "† bake s of a bake of its own" in md and alpha_cells and alpha_cells[0].count("†") == 1, md[-900:])
    cached = {r["model"]: (r.get("truth_s_cached"), r.get("bake_s_cached"), r.get("render_ms_cached"))
              for r in doc["rows"] if r["kind"] == "model"}
    report("the rows say which times come from an earlier run: the truth's and binary's, not alpha's rerun ones",
           cached == {"alpha": (1, 0, 0), "binary": (1, 1, 1)}, str(cached))
    report("Table 2 marks those three times with a double dagger (and only them) and says what it means",
           "‡ measured in an earlier run" in md and alpha_cells and alpha_cells[0].count("‡") == 3 and
           "‡" in alpha_cells[0].split("|")[5], md[-900:])  # the truth s column
    report("rows.json lists the invalidated entries", len(inv) == 3 and
           {x["kind"] for x in inv} == {"bake", "render", "compare"}, str(inv)[:500])
    edit(root, "tracer/truth/truth.c")
    rebuilt(root)
    p, ran = sweep(root)
    report("editing the truth renderer reruns the truth and the compares only",
           [k for k, _ in ran] == ["compare", "compare", "truth"], f"ran {ran}")
    edit(root, "tracer/render/render.c")
    rebuilt(root)
    p, ran = sweep(root)
    report("editing the voxel renderer reruns every model job, not the truth",
           [k for k, _ in ran] == ["bake"] * 2 + ["compare"] * 2 + ["render"] * 2, f"ran {ran}")
    p, ran = sweep(root, "--force")
    report("--force reruns every job", p.returncode == 0 and len(ran) == 7, f"ran {ran}")
    # The same sources built otherwise (make OPT=-O0, SANITIZE=1): a binary whose `--version` names
    # another build line runs every job again, and the rows name its build; the first build's entries
    # are still there for it.
    exe = os.path.join(root, "build", "voxlab")
    os.rename(exe, exe + ".real")
    with open(exe, "w") as f:
        f.write('#!/bin/sh\nif [ "$1" = "--version" ]; then echo "voxlab wrapped"; '
                'echo "build: gcc -O0 (another build)"; exit 0; fi\nexec "%s.real" "$@"\n' % exe)
    os.chmod(exe, 0o755)
    p, ran = sweep(root)
    with open(os.path.join(root, "results", "tiny", "rows.json")) as f:
        meta = json.load(f)["meta"]
    report("a binary built with other flags reruns every job and the rows name its build",
           p.returncode == 0 and len(ran) == 7 and meta.get("voxlab_build") == "gcc -O0 (another build)",
           f"ran {ran}, build {meta.get('voxlab_build')}\n{p.stderr[-800:]}")
    os.replace(exe + ".real", exe)
    rebuilt(root)
    p, ran = sweep(root)
    with open(os.path.join(root, "results", "tiny", "rows.json")) as f:
        meta = json.load(f)["meta"]
    report("back to the first build: every job cached, its build line in the rows",
           p.returncode == 0 and ran == [] and "-O" in meta.get("voxlab_build", "") and
           meta["voxlab_build"] != "gcc -O0 (another build)", f"ran {ran}, build {meta.get('voxlab_build')}")
    edit(root, "models/binary/binary.c")  # and no rebuild
    os.utime(os.path.join(root, "models", "binary", "binary.c"), (time.time() + 60, time.time() + 60))
    p, ran = sweep(root)
    report("sources newer than the binary are refused", p.returncode == 1 and "older than" in p.stderr and
           "models/binary/binary.c" in p.stderr and not ran, p.stderr[-600:])


def main():
    linker_checks()
    sweep_checks()


if __name__ == "__main__":
    main()
    finish()
