"""results/history.csv: written by `make dashboard` only (dashboard.py --record-history), one line per
(commit, job). Recording the same commit twice keeps one line per configuration with the newest
numbers; another commit adds its own lines; an old file with duplicate lines is compacted; running
an experiment (regress.py, whose declaration says "history": true) writes no history, and the
dashboard without --record-history does not either."""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_csv, report  # noqa: E402

EXP = os.path.join(REPO, "experiments")
sys.path.insert(0, EXP)
from voxlab_exp.history import baseline_section, compare_to_baseline, gating, record_history  # noqa: E402

PY = "/usr/bin/python3"


def fake_run(commit, mse, date="2026-01-01T00:00:00+00:00"):
    meta = {"experiment": "e", "date": date, "git": {"commit": commit, "dirty": False},
            "machine": {"host": "h"}, "voxlab_sha256": "ab" * 32}
    rows = [{"scene": "s", "model": m, "res": 64, "width": 64, "height": 64, "spp": 4, "rays": 150, "cache": True,
             "status": "ok", "mse": mse, "ssim": 0.9, "experiment": "e"} for m in ("a", "b", "c")]
    return meta, rows


def unit():
    path = os.path.join(TMP, "h.csv")
    record_history(path, [fake_run("1" * 40, 0.1)], TMP)
    record_history(path, [fake_run("1" * 40, 0.2, "2026-01-02T00:00:00+00:00")], TMP)
    h = read_csv(path)
    report("same commit twice: one line per job, the newest numbers",
           len(h) == 3 and all(x["mse"] == "0.2" for x in h), str(h)[:400])
    record_history(path, [fake_run("2" * 40, 0.3)], TMP)
    h = read_csv(path)
    report("another commit adds its own lines", len(h) == 6 and {x["commit"] for x in h} == {"1" * 40, "2" * 40}, "")
    with open(path) as f:
        lines = f.read().splitlines()
    with open(path, "w") as f:  # an old file: every run appended, three copies of each line
        f.write("\n".join(lines + lines[1:] + lines[1:]) + "\n")
    record_history(path, [], TMP)
    report("duplicate lines of an old history are compacted", len(read_csv(path)) == 6, "")


def history_configurations():
    """Rows differing only by shadows, shadow skip, seed or the truth's spp are lines of their own in
    history.csv (they overwrote each other's)."""
    path = os.path.join(TMP, "h_configs.csv")
    meta, rows = fake_run("5" * 40, 0.1)
    base = dict(rows[0], kind="model", shadows="march", shadow_skip=True, seed=1, truth_spp=16)
    variants = [base, dict(base, shadows="slicemap", mse=0.2), dict(base, shadow_skip=False, mse=0.3),
                dict(base, seed=2, mse=0.4), dict(base, truth_spp=64, mse=0.5)]
    record_history(path, [(meta, variants)], TMP)
    h = read_csv(path)
    report("history: shadows, shadow skip, seed and truth spp are each a configuration of its own",
           sorted(x["mse"] for x in h) == ["0.1", "0.2", "0.3", "0.4", "0.5"] and
           {x["shadows"] for x in h} == {"march", "slicemap"}, str([(x["mse"], x.get("shadows")) for x in h]))


def shadow_skip_keys():
    """Rows that differ only by shadow_skip are two configurations in the baseline (row_key): they were
    one key, so the baseline kept the last and the regression check compared the shadow-skip row
    against the no-skip row's numbers and called the other "new"."""
    meta, rows = fake_run("3" * 40, 0.1)
    rows = [dict(rows[0], kind="model", shadow_skip=True, shadows="march", truth_spp=16, seed=1),
            dict(rows[0], kind="model", shadow_skip=False, shadows="march", truth_spp=16, seed=1, mse=0.2)]
    meta.update(models=[{"name": "a"}], metrics=["mse"])
    section = baseline_section(meta, rows)
    res = compare_to_baseline(rows, section, {"mse": {"better": "lower", "rel": 0.05}})
    report("shadow_skip true and false: two baseline entries, each compared with its own",
           len(section["entries"]) == 2 and [x["status"] for x in res] == ["ok", "ok"] and
           [x["metrics"]["mse"]["base"] for x in res] == [0.1, 0.2], str(section["entries"])[:400])


def failed_new_configuration():
    """A configuration the baseline lacks that fails is a failure that gates the check, not "new"
    (its blank metrics looked like a missing row's and regress passed)."""
    meta, rows = fake_run("4" * 40, 0.1)
    rows = [dict(rows[0], kind="model", shadow_skip=True, shadows="march", truth_spp=16, seed=1)]
    meta.update(models=[{"name": "a"}], metrics=["mse"])
    section = baseline_section(meta, rows)
    failing = dict(rows[0], model="b", status="error", error="voxlab render: boom", mse=None)
    res = compare_to_baseline(rows + [failing], section, {"mse": {"better": "lower", "rel": 0.05}})
    report("a new configuration that fails: status failed, with its error, and it gates the check",
           [x["status"] for x in res] == ["ok", "failed"] and res[1].get("error") == "voxlab render: boom" and
           [x["model"] for x in gating(res)] == ["b"], str([(x["model"], x["status"]) for x in res]))


def no_writers():
    results = os.path.join(TMP, "results")
    decl = os.path.join(TMP, "hist.json")
    with open(decl, "w") as f:
        json.dump({"name": "hist", "truth_spp": 16, "scenes": ["spheres"], "history": True, "repeats": 1,
                   "runs": [{"models": ["binary"], "res": [16], "size": 16, "spp": [1]}]}, f)
    base = os.path.join(TMP, "baseline.json")
    common = ["--experiment", decl, "--results", results, "--voxlab", VOXLAB, "--baseline", base]
    p1 = subprocess.run([PY, os.path.join(EXP, "regress.py"), *common, "--write-baseline", "--allow-dirty"],
                        capture_output=True, text=True)
    p2 = subprocess.run([PY, os.path.join(EXP, "regress.py"), *common], capture_output=True, text=True)
    hist = os.path.join(results, "history.csv")
    report("regress writes no history", p1.returncode == 0 and p2.returncode == 0 and not os.path.exists(hist),
           p1.stderr[-500:] + p2.stderr[-500:])
    dash = [PY, os.path.join(EXP, "dashboard.py"), "--results", results, "--baseline", base, "--experiments", "hist",
            "--voxlab", VOXLAB, "--out", os.path.join(results, "dashboard")]
    p = subprocess.run(dash, capture_output=True, text=True)
    report("the dashboard page alone writes no history", p.returncode == 0 and not os.path.exists(hist),
           p.stderr[-500:])
    for _ in range(2):
        p = subprocess.run(dash + ["--record-history"], capture_output=True, text=True)
    h = read_csv(hist) if os.path.exists(hist) else []
    report("dashboard --record-history: one line per (commit, job), twice recorded", p.returncode == 0 and
           len(h) == 1 and h[0]["model"] == "binary", p.stderr[-500:] + str(h)[:300])


def main():
    unit()
    shadow_skip_keys()
    history_configurations()
    failed_new_configuration()
    no_writers()


if __name__ == "__main__":
    main()
    finish()
