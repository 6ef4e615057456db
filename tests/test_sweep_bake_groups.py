"""The sweep's bakes in one pass of the sampler (issue 15: bakes were 84 % of table1's CPU time and
every model reads the same sample rays). The bakes of one scene, resolution, rays and seed run as one
`voxlab bake --model a,b,c`; each model keeps its own cache entry, .vox and timing. Checked against
independent references: each cached .vox is byte-identical to a `voxlab bake` of that model alone;
each entry's timing runs are its own model's bake_seconds (the stats file beside it), repeated as
asked; a model added later bakes alone and the others stay cached; --separate-bakes runs one voxlab
per model and gives the same files; a failing pass fails every model of it, as rows, without
stopping the sweep; no temporary folder is left behind."""
import glob
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_csv, report, voxlab  # noqa: E402

EXP = os.path.join(REPO, "experiments")
SPHERES = os.path.join(REPO, "scenes", "spheres.json")
MODELS = ["binary", "alpha", "vmesh"]


def declare(name, models, res=20, bake_repeats=2):
    d = {"name": name, "truth_spp": 4, "scenes": ["spheres"], "bake_repeats": bake_repeats, "repeats": 1,
         "runs": [{"models": models, "res": [res], "size": 16, "spp": [1], "rays": [24]}]}
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(d, f)
    return path


def sweep(decl, results, *extra, env=None):
    return subprocess.run([sys.executable, os.path.join(EXP, "sweep.py"), decl, "--results", results,
                           "--voxlab", VOXLAB, "--jobs", "2", *extra], capture_output=True, text=True,
                          env=None if env is None else {**os.environ, **env})


def entries(cache):
    """model -> (job.json, stats.json, .vox path) of every bake entry in the cache."""
    out = {}
    for d in glob.glob(os.path.join(cache, "bake", "*")):
        if not os.path.isfile(os.path.join(d, "job.json")):
            continue
        job = json.load(open(os.path.join(d, "job.json")))
        out[job["inputs"]["model"]] = (job, json.load(open(os.path.join(d, "stats.json"))),
                                       os.path.join(d, "model.vox"))
    return out


def read(p):
    with open(p, "rb") as f:
        return f.read()


def leftovers(root):
    return [os.path.join(r, n) for r, ds, fs in os.walk(root) for n in ds + fs if ".tmp." in n or ".group" in n]


def main():
    # The reference: each model baked alone by voxlab itself.
    alone = {}
    for m in MODELS + ["vicini"]:
        alone[m] = os.path.join(TMP, f"alone_{m}.vox")
        voxlab("bake", SPHERES, "--model", m, "--res", "20", "--rays", "24", "--seed", "1", "-o", alone[m])

    results = os.path.join(TMP, "grouped")
    cache = os.path.join(results, "cache")
    p = sweep(declare("groups", MODELS), results)
    report("grouped sweep exits 0", p.returncode == 0, p.stderr[-1500:])
    e = entries(cache)
    report("one bake entry per model", sorted(e) == sorted(MODELS), str(sorted(e)))
    labels = {m: e[m][0]["label"] for m in e}
    for m, (job, stats, vox) in sorted(e.items()):
        cmd = job["command"]
        report(f"{m}: baked in one pass with the others (one voxlab bake --model {','.join(MODELS)})",
               "--model" in cmd and sorted(cmd[cmd.index("--model") + 1].split(",")) == sorted(MODELS)
               and sorted(job.get("baked_with", [])) == sorted(labels[o] for o in MODELS if o != m), str(job))
        report(f"{m}: its .vox is byte-identical to its own bake's", read(vox) == read(alone[m]))
        runs = (job.get("timing") or {}).get("runs", [])
        report(f"{m}: timing = its own bake_seconds, 2 runs ({runs}; stats {stats.get('bake_seconds')})",
               job["timing"]["field"] == "bake_seconds" and len(runs) == 2 and runs[0] == stats["bake_seconds"]
               and stats["model"] == m and stats.get("baked_together") is not None, str(stats)[:400])
        report(f"{m}: its stats say the pass was shared (bake_pass_seconds >= its own bake_seconds - finish)",
               stats["bake_pass_seconds"] >= stats["bake_seconds"] - stats["bake_finish_seconds"] - 1e-9)
    report("progress names the shared pass", p.stderr.count("one pass with 2 other model(s)") == len(MODELS),
           p.stderr[-1500:])
    rows = {r["model"]: r for r in read_csv(os.path.join(results, "groups", "rows.csv"))}
    report("rows: bake_s is each model's own median",
           all(m in rows and float(rows[m]["bake_s"]) == e[m][0]["timing"]["median"] for m in MODELS), str(rows)[:600])
    report("no temporary folders left", not leftovers(results), str(leftovers(results)[:5]))

    # A model added later: its bake runs alone; the others are cached.
    p = sweep(declare("groups_more", MODELS + ["vicini"]), results)
    e2 = entries(cache)
    report("an added model bakes alone, the others stay cached",
           p.returncode == 0 and "vicini" in e2 and "baked_with" not in e2["vicini"][0]
           and "3 job(s) to run" in p.stderr
           and all(e2[m][0]["started_at"] == e[m][0]["started_at"] for m in MODELS), p.stderr[-1500:])
    report("the added model's .vox is its own bake's", "vicini" in e2 and read(e2["vicini"][2]) == read(alone["vicini"]))

    # --separate-bakes: one voxlab per model, the same files.
    sep = os.path.join(TMP, "separate")
    p = sweep(declare("groups", MODELS), sep, "--separate-bakes")
    e3 = entries(os.path.join(sep, "cache"))
    report("--separate-bakes: one voxlab bake per model, the same .vox files",
           p.returncode == 0 and sorted(e3) == sorted(MODELS)
           and all("baked_with" not in e3[m][0] and e3[m][0]["command"][e3[m][0]["command"].index("--model") + 1] == m
                   and read(e3[m][2]) == read(alone[m]) for m in MODELS), p.stderr[-1500:])

    # A pass that fails fails each of its models, as rows; the sweep completes. The declaration checks
    # refuse what voxlab's options refuse, so the pass fails on voxlab's memory estimate: 1024^3 voxels
    # need about 0.27 GiB, over the 50 MB budget given to voxlab here (the truth needs a few MB).
    bad = os.path.join(TMP, "failing")
    p = sweep(declare("groups_fail", MODELS[:2], res=1024, bake_repeats=1), bad, env={"VOXLAB_MEMORY_BUDGET": "50000000"})
    rows = read_csv(os.path.join(bad, "groups_fail", "rows.csv")) if p.returncode == 0 else []
    report("a failing pass: every model of it a failed row, the sweep completes",
           p.returncode == 0 and len(rows) == 2 and all(r["status"] == "failed" and "voxlab bake" in r["error"]
                                                        for r in rows), p.stderr[-1500:] + str(rows)[:400])
    report("a failing pass leaves no entry and no temporary folder",
           not entries(os.path.join(bad, "cache")) and not leftovers(bad), str(leftovers(bad)[:5]))


main()
finish()
