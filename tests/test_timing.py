"""Timings a paper can quote (experiments/jobexec.py, voxlab_exp/rows.py, pareto.py, table1.py).

- A timed job runs its voxlab command R times: the record holds every run's time as voxlab's own
  --stats reported it (read back here from each run's stats file, independently), with min, median
  and spread (max - min); the rows, Table 2 and pareto.csv use the median, min and spread.
- The load: a job measured under a 1-minute load above the cores is flagged (os.getloadavg replaced
  in-process to make the machine look busy and idle), the row says loaded = 1 and the tables'
  settings say FLAGGED.
- Where timed jobs ran: each row's host and threads; the tables name the machine, or warn when a
  cluster timed jobs on several.
- `make bench` (tests/bench.sh) prints the machine's load averages before and after every
  benchmark: run with stub benchmarks in a BUILD of its own, each stub's output lies between a
  "before" and an "after" line naming it, with three load figures each.
- The truth's memory in the rows: voxlab's mesh_bytes (within the bounds the triangle count sets)
  plus its bvh_bytes, not its peak RSS.
- The truth's render time is monotone in spp within the spread on a small case (spheres, 64x64,
  4/16/64 spp, 3 repeats), checked from pareto.csv's numbers here and stated in pareto.md; the
  check itself (truth_time_violations) against hand-made points.
- A sweep over the shadow method and the shadow skip: pareto.csv's columns and labels tell the
  points apart, and the memory axis charges the `voxel` method its per-voxel transmittances.
"""
# run_all: alone (its checks compare times it measures: tests/run_all.sh)
import json
import os
import statistics
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_csv, report  # noqa: E402

EXP = os.path.join(REPO, "experiments")
sys.path.insert(0, EXP)
import jobexec  # noqa: E402
import pareto  # noqa: E402
from voxlab_exp.cli import sweep_args  # noqa: E402
from voxlab_exp.rows import run_experiment  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

PY = "/usr/bin/python3"


def sweep_options(results):
    """The command line's options (voxlab_exp.cli.sweep_args) for an in-process sweep into TMP/results."""
    return type("A", (), {"results": os.path.join(TMP, results), "cache": None, "voxlab": VOXLAB, "jobs": 2,
                          "fresh": False, "executor": "local", "scheduler": None, "slurm_args": "", "repeats": None})


def repeated_runs():
    """jobexec.execute on a truth spec with 3 repeats keeps each run's stats (patched to keep them)."""
    d = os.path.join(TMP, "exec")
    os.makedirs(d, exist_ok=True)
    seen = []
    real = jobexec.run_measured

    def spy(cmd, timeout=None):
        r = real(cmd, timeout)
        stats = cmd[cmd.index("--stats") + 1]
        with open(stats) as f:
            seen.append(json.load(f)["seconds"])
        return r

    spec = {"key": "k", "identity": "i", "kind": "truth", "label": "spheres-test", "dir": os.path.join(d, "job"),
            "cmd": [VOXLAB, "truth", os.path.join(REPO, "scenes", "spheres.json"), "--spp", "4", "--size", "24x24",
                    "--threads", "{threads}", "-o", "{tmp}/image.exr", "--stats", "{tmp}/stats.json"],
            "outputs": ["image.exr", "image.png", "stats.json"], "timed": True, "repeats": 3,
            "timing_field": "seconds", "timeout": 60, "inputs": {}}
    loads = iter([(0.2, 0, 0), (0.3, 0, 0), (99.0, 0, 0), (99.0, 0, 0)])
    real_load = os.getloadavg
    jobexec.run_measured = spy
    os.getloadavg = lambda: next(loads)
    try:
        rec = jobexec.execute(spec)
        spec["dir"] = os.path.join(d, "job2")
        busy = jobexec.execute({**spec, "repeats": 1})
    finally:
        jobexec.run_measured = real
        os.getloadavg = real_load
    t = rec.get("timing", {})
    runs = seen[:3]
    report("a timed job runs its command R times and records each run's own time",
           t.get("runs") == runs and len(runs) == 3, f"record {t}, stats files {runs}")
    report("min, median and spread of the runs",
           t.get("min") == min(runs) and t.get("median") == sorted(runs)[1] and
           abs(t.get("spread", -1) - (max(runs) - min(runs))) < 1e-15, str(t))
    report("one output kept, the repeats' removed", sorted(os.listdir(os.path.join(d, "job"))) ==
           ["image.exr", "image.png", "job.json", "stats.json"], str(os.listdir(os.path.join(d, "job"))))
    report("a timed job takes every core", rec.get("threads") == os.cpu_count(), str(rec.get("threads")))
    report("load below the cores: not flagged; above: flagged",
           rec.get("loaded") is False and busy.get("loaded") is True and busy.get("load_average") == 99.0,
           f"{rec.get('loaded')} {busy.get('loaded')} {busy.get('load_average')}")


def violations_logic():
    def p(spp, lo, spread):
        return {"spp": spp, "render_ms_min": lo, "render_ms_spread": spread, "render_ms": lo + spread / 2}

    ok = [p(1, 10, 2), p(4, 11, 5), p(16, 40, 3)]
    noisy = [p(1, 10, 4), p(4, 9, 2)]  # 4 spp's slowest (11) overlaps 1 spp's runs: within the spread
    bad = [p(1, 10, 1), p(4, 5, 1)]  # 4 spp's slowest (6) beats 1 spp's fastest (10)
    report("monotone check: rising, overlapping and falling cases",
           pareto.truth_time_violations(ok) == [] and pareto.truth_time_violations(noisy) == [] and
           [(a["spp"], b["spp"]) for a, b in pareto.truth_time_violations(bad)] == [(1, 4)], "")


def run_pareto(declaration, what):
    """Writes the declaration, runs pareto.py on it: its results folder and output folder, or None
    (reported) when it failed."""
    decl = os.path.join(TMP, declaration["name"] + ".json")
    with open(decl, "w") as f:
        json.dump(declaration, f)
    results = os.path.join(TMP, "results")
    p = subprocess.run([PY, os.path.join(EXP, "pareto.py"), "--experiment", decl, "--results", results,
                        "--voxlab", VOXLAB], capture_output=True, text=True)
    report(f"{what} exits 0", p.returncode == 0, p.stderr[-1500:])
    return (results, os.path.join(results, declaration["name"])) if p.returncode == 0 else (None, None)


def pareto_small():
    results, out = run_pareto({"name": "pareto_small", "truth_spp": 256, "scenes": ["spheres"], "repeats": 3,
                               "runs": [{"models": ["alpha"], "res": [16], "size": 64, "spp": [4]}],
                               "truth_curve": {"spp": [4, 16, 64], "seed": 2, "size": 64}}, "small pareto sweep")
    if out is None:
        return
    rows = read_csv(os.path.join(out, "pareto.csv"))
    truth = sorted((r for r in rows if r["series"] == "truth"), key=lambda r: int(r["spp"]))
    with open(os.path.join(out, "rows.json")) as f:
        jrows = json.load(f)["rows"]
    # Each point's median from the job records themselves.
    ok = True
    for r in jrows:
        job = os.path.join(results, os.path.dirname(r["image"]), "job.json")
        with open(job) as f:
            runs = json.load(f)["timing"]["runs"]
        ok &= len(runs) == 3 and abs(r["render_ms"] - 1000 * statistics.median(runs)) < 1e-9 and \
            abs(r["render_ms_spread"] - 1000 * (max(runs) - min(runs))) < 1e-9
    report("rows: render ms = median of the job's 3 runs, spread = max - min", ok and len(jrows) == 4, "")
    lo = [float(r["render_ms_min"]) for r in truth]
    hi = [float(r["render_ms_min"]) + float(r["render_ms_spread"]) for r in truth]
    mono = all(hi[j] >= lo[i] for i in range(len(truth)) for j in range(i + 1, len(truth)))
    print("# truth render ms (min..max of 3) by spp: " +
          ", ".join(f"{r['spp']}: {a:.3f}..{b:.3f}" for r, a, b in zip(truth, lo, hi)))
    report("truth time monotone in spp within the spread (spheres 64x64, 4/16/64 spp)", len(truth) == 3 and mono,
           str(list(zip(lo, hi))))
    with open(os.path.join(out, "pareto.md")) as f:
        md = f.read()
    report("pareto.md states the monotone check", ("monotone within the spread" in md) == mono and
           "truth render time against spp" in md, md[-600:])
    report("pareto plot written", os.path.isfile(os.path.join(out, "pareto_spheres.png")), "")
    # The truth's memory: its meshes' arrays and its BVH, as a model's is its records and grid. The
    # arrays lie between 16 bytes a triangle + one 44-byte vertex and 16 + 3 x 44 a triangle (each
    # triangle its own three vertices).
    # Each row against its own job's stats.json: Embree's BVH bytes vary a little from one build to
    # the next (its threads' allocation blocks), so rows of different truth jobs need not agree.
    tj = [r for r in jrows if r["kind"] == "truth"]
    ok, seen = bool(tj), []
    for r in tj:
        with open(os.path.join(results, os.path.dirname(r["image"]), "stats.json")) as f:
            ts = json.load(f)
        tri = ts["triangles"]
        seen.append((r["mb"], ts.get("mesh_bytes"), ts.get("bvh_bytes"), tri))
        ok &= abs(r["mb"] - (ts["mesh_bytes"] + ts["bvh_bytes"]) / 1e6) < 1e-9 and \
            16 * tri + 44 <= ts["mesh_bytes"] <= (16 + 3 * 44) * tri and ts["bvh_bytes"] > 0
    report("the truth's MB = voxlab's mesh_bytes + bvh_bytes, mesh_bytes within the arrays' bounds", ok,
           f"(mb, mesh, bvh, triangles) per row: {seen}")


def pareto_shadow_settings():
    """A declaration that sweeps the shadow method and the shadow skip: pareto.csv says which point is
    which (columns and labels), and the memory axis charges the `voxel` method its transmittances
    (one float per voxel and light, counted here from the row's voxels and the scene's lights)."""
    _, out = run_pareto({"name": "pareto_shadows", "truth_spp": 16, "scenes": ["spheres"], "repeats": 1,
                         "runs": [{"models": ["alpha"], "res": [16], "size": 32, "spp": [4],
                                   "shadows": ["march", "voxel"], "shadow_skip": [True, False]}]},
                        "pareto sweep over shadow settings")
    if out is None:
        return
    rows = [r for r in read_csv(os.path.join(out, "pareto.csv")) if r["series"] == "alpha"]
    by = {(r["shadows"], r["shadow_skip"]): r for r in rows}
    report("pareto.csv: one alpha point per shadow method and skip, with both columns",
           len(rows) == 4 and set(by) == {(m, k) for m in ("march", "voxel") for k in ("True", "False")},
           str(sorted(by)))
    labels = {k: r["label"] for k, r in by.items()}
    report("the labels name the shadow method and the skip where they are not the default",
           len(labels) == 4 and "shadow" not in labels[("march", "True")] and
           "voxel shadows" in labels[("voxel", "True")] and "no shadow skip" not in labels[("voxel", "True")] and
           "no shadow skip" in labels[("march", "False")] and "voxel shadows" not in labels[("march", "False")] and
           "voxel shadows" in labels[("voxel", "False")] and "no shadow skip" in labels[("voxel", "False")],
           str(labels))
    with open(os.path.join(out, "rows.json")) as f:
        jrows = [r for r in json.load(f)["rows"] if r["kind"] == "model"]
    with open(os.path.join(REPO, "scenes", "spheres.json")) as f:
        lights = len(json.load(f)["lights"])
    ok, seen = len(jrows) == 4, []
    for skip in (True, False):
        m = [r for r in jrows if r["shadows"] == "march" and r["shadow_skip"] == skip]
        v = [r for r in jrows if r["shadows"] == "voxel" and r["shadow_skip"] == skip]
        if len(m) != 1 or len(v) != 1:
            ok = False
            continue
        m, v = m[0], v[0]
        transmittances = 4 * v["voxels"] * lights / 1e6
        seen.append((m["mb"], v["mb"], transmittances))
        ok &= v["voxels"] > 0 and abs(v["mb"] - m["mb"] - transmittances) < 1e-9
    report("memory: a voxel-shadowed point costs its march twin + 4 bytes per voxel and light", ok,
           f"(march mb, voxel mb, transmittances MB): {seen}")


def flagged_in_tables():
    """A sweep whose machine looks overloaded: rows loaded = 1, Table 2 marks the times, the
    settings line flags the jobs."""
    decl = os.path.join(TMP, "busy.json")
    with open(decl, "w") as f:
        json.dump({"name": "busy", "truth_spp": 8, "scenes": ["spheres"], "repeats": 2,
                   "runs": [{"models": ["binary"], "res": [8], "size": 16, "spp": [1]}]}, f)
    real = os.getloadavg
    os.getloadavg = lambda: (float(os.cpu_count() + 5), 0.0, 0.0)
    try:
        import table1

        a = sweep_options("busy-results")
        meta, rows = run_experiment(load_declaration(decl), **sweep_args(a))
        table1.build(meta, rows, load_declaration(decl), os.path.join(a.results, "busy"))
    finally:
        os.getloadavg = real
    with open(os.path.join(a.results, "busy", "table2.md")) as f:
        md = f.read()
    report("a loaded measurement is flagged in the rows and tables",
           rows[0]["loaded"] == 1 and "FLAGGED" in md and "*" in md.split("| spheres |")[1].split("\n")[0] and
           rows[0]["repeats"] == 2, md[-900:])


def bench_load_lines():
    """tests/bench.sh with every tests/bench_* replaced by a stub that prints its name: each stub's line
    sits between its own before and after load lines."""
    import re
    build = os.path.join(TMP, "bench-stubs")
    os.makedirs(os.path.join(build, "tests"), exist_ok=True)
    with open(os.path.join(REPO, "tests", "bench.sh")) as f:
        script = f.read()
    names = sorted(set(re.findall(r'"\$BUILD"/tests/(bench_[a-z_]+)', script)))
    for n in names:
        stub = os.path.join(build, "tests", n)
        with open(stub, "w") as f:
            f.write("#!/bin/sh\necho STUB %s \"$@\"\n" % n)
        os.chmod(stub, 0o755)
    r = subprocess.run(["bash", os.path.join(REPO, "tests", "bench.sh")], env={**os.environ, "BUILD": build},
                       capture_output=True, text=True, timeout=120)
    lines = r.stdout.splitlines()
    load = r"load average [0-9.]+ [0-9.]+ [0-9.]+"
    stubs = [i for i, line in enumerate(lines) if line.startswith("STUB ")]
    framed = all(0 < i < len(lines) - 1 and re.fullmatch(r"== %s .*: %s before" % (lines[i].split()[1], load),
                                                           lines[i - 1]) is not None and
                 re.fullmatch(r"== %s: %s after" % (lines[i].split()[1], load), lines[i + 1]) is not None
                 for i in stubs)
    unwrapped = [line for line in script.splitlines() if '"$BUILD"/tests/' in line and
                 not line.lstrip().startswith("bench ")]
    report("make bench prints the load before and after each of its %d benchmarks" % len(stubs),
           r.returncode == 0 and len(names) >= 8 and {lines[i].split()[1] for i in stubs} == set(names) and framed and
           not unwrapped, r.stdout[-1500:] + r.stderr[-500:] + repr(unwrapped))


def machines_in_tables():
    """Where the timed jobs ran: every row names its host and threads (from its job's record), and the
    tables' settings name the one machine, or warn when timed jobs ran on several (a cluster)."""
    import platform
    from voxlab_exp.report import machines_text
    decl = os.path.join(TMP, "machines.json")
    with open(decl, "w") as f:
        json.dump({"name": "machines", "truth_spp": 8, "scenes": ["spheres"], "repeats": 1,
                   "runs": [{"models": ["binary"], "res": [8], "size": 16, "spp": [1]}]}, f)
    a = sweep_options("machines-results")
    meta, rows = run_experiment(load_declaration(decl), **sweep_args(a))
    here = f"{platform.node()} ({os.cpu_count()} threads)"
    report("rows name the host and threads of their timed jobs; the meta the one machine",
           rows and all(r["host"] == platform.node() and r["threads"] == os.cpu_count() for r in rows) and
           meta["timed_machines"] == [here] and machines_text(meta) == f"on {here}",
           str([(r["host"], r["threads"]) for r in rows]) + str(meta.get("timed_machines")))
    two = dict(meta, timed_machines=["a (2 threads)", "b (16 threads)"])
    text = machines_text(two)
    report("timed jobs on two machines: the tables' settings warn and name both",
           "CAUTION" in text and "a (2 threads)" in text and "b (16 threads)" in text, text)


def main():
    bench_load_lines()
    machines_in_tables()
    repeated_runs()
    violations_logic()
    flagged_in_tables()
    pareto_small()
    pareto_shadow_settings()


if __name__ == "__main__":
    main()
    finish()
