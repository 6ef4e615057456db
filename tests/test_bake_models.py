"""`voxlab bake --model a,b,c`: several models baked from one pass of the sampler (issue 15: the
tracing of the sample rays is most of a bake, and every model reads the same rays). Checked against
the independent reference of separate bakes: each model's .vox is byte-identical to its own bake's,
whatever the thread count; each model gets its own --stats, which says the pass was shared and
splits the pass's time between the samples and each model (the parts add up to the pass; a model
baked alone has the whole pass as its time); bad
lists and paths are refused before anything is written; a failed write leaves none of the run's
files."""
import json
import os
import subprocess

from testlib import REPO, TMP, VOXLAB, finish, report, voxlab

SPHERES = os.path.join(REPO, "scenes", "spheres.json")
MODELS = ["binary", "alpha", "vmesh", "heitz-neyret", "vicini"]
BAKE = ["--res", "20", "--rays", "24", "--seed", "3"]


def path(*names):
    return os.path.join(TMP, *names)


def run(*args):
    return subprocess.run([VOXLAB, "bake", SPHERES, *map(str, args)], capture_output=True, text=True)


def read(p):
    with open(p, "rb") as f:
        return f.read()


# ---------- the reference: one bake per model ----------
single = {}
for m in MODELS:
    single[m] = path(f"single_{m}.vox")
    voxlab("bake", SPHERES, "--model", m, *BAKE, "--threads", "1", "-o", single[m], "--stats", path(f"single_{m}.json"))


def close(a, b):
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b), 1e-6)


def times(j):
    return [j.get(k) for k in ("bake_seconds", "bake_pass_seconds", "bake_sampling_seconds", "bake_finish_seconds")]


for m in MODELS:
    j = json.load(open(path(f"single_{m}.json")))
    total, pass_s, sampling, own_finish = times(j)
    report(f"{m} baked alone: bake_seconds {total} = the pass {pass_s} + its bake_finish {own_finish}, and the "
           f"samples {sampling} are part of the pass", None not in (total, pass_s, sampling, own_finish)
           and close(total, pass_s + own_finish) and 0 < sampling <= pass_s and own_finish >= 0
           and j.get("seconds") == total,
           str(j))

# ---------- one pass, every model ----------
for threads in (1, 2):
    d = path(f"shared_t{threads}")
    os.makedirs(d, exist_ok=True)
    p = run("--model", ",".join(MODELS), *BAKE, "--threads", threads, "-o", os.path.join(d, "{model}.vox"),
            "--stats", os.path.join(d, "{model}.json"))
    report(f"shared bake ({threads} threads): exit 0", p.returncode == 0, p.stderr)
    for m in MODELS:
        out = os.path.join(d, f"{m}.vox")
        report(f"shared bake ({threads} threads): {m}'s .vox is byte-identical to its own bake's",
               os.path.exists(out) and read(out) == read(single[m]))
        st = os.path.join(d, f"{m}.json")
        ok = os.path.exists(st)
        j = json.load(open(st)) if ok else {}
        report(f"shared bake ({threads} threads): {m}'s --stats names it and the models baked with it",
               ok and j.get("model") == m and j.get("baked_together") == MODELS and j.get("bake_rays", 0) > 0, str(j))
    # The pass's time: the same pass and samples in every model's stats; each model's own part
    # (bake_seconds without its finish and the samples) between 0 and the pass, and the parts and
    # the samples adding up to the pass (not every model charged the whole pass).
    st = [json.load(open(os.path.join(d, f"{m}.json"))) for m in MODELS]
    t = [times(j) for j in st]
    ok = all(None not in x for x in t)
    pass_s, sampling = (t[0][1], t[0][2]) if ok else (None, None)
    own = [x[0] - x[3] - x[2] for x in t] if ok else []
    report(f"shared bake ({threads} threads): one pass ({pass_s} s) and one sampling time ({sampling} s) in every "
           f"model's stats", ok and all(x[1] == pass_s and x[2] == sampling for x in t) and 0 < sampling <= pass_s)
    report(f"shared bake ({threads} threads): the models' own parts {[round(o, 6) for o in own]} and the samples add "
           f"up to the pass", ok and all(-1e-9 <= o <= pass_s for o in own) and close(sampling + sum(own), pass_s))

# A subset, in another order, with a path that is not only {model}.
d = path("subset")
os.makedirs(d, exist_ok=True)
p = run("--model", "vicini,alpha", *BAKE, "-o", os.path.join(d, "bake-{model}-20.vox"))
report("a subset in another order: each file is its model's own bake",
       p.returncode == 0 and read(os.path.join(d, "bake-vicini-20.vox")) == read(single["vicini"])
       and read(os.path.join(d, "bake-alpha-20.vox")) == read(single["alpha"]), p.stderr)
# One model keeps working as before, {model} or not.
p = run("--model", "alpha", *BAKE, "-o", path("one_{model}.vox"))
report("one model: {model} in -o is its name", p.returncode == 0 and read(path("one_alpha.vox")) == read(single["alpha"]),
       p.stderr)

# ---------- refused before anything is written ----------
bad = path("bad")
os.makedirs(bad, exist_ok=True)
cases = [
    ("-o without {model}", ["--model", "alpha,vmesh", *BAKE, "-o", os.path.join(bad, "x.vox")], ["{model}", "-o"]),
    ("--stats without {model}", ["--model", "alpha,vmesh", *BAKE, "-o", os.path.join(bad, "{model}.vox"), "--stats",
                                 os.path.join(bad, "s.json")], ["{model}", "--stats"]),
    ("an unknown model in the list", ["--model", "alpha,nosuch", *BAKE, "-o", os.path.join(bad, "{model}.vox")],
     ["nosuch", "unknown model"]),
    ("a model named twice", ["--model", "alpha,vmesh,alpha", *BAKE, "-o", os.path.join(bad, "{model}.vox")],
     ["alpha", "twice"]),
    ("an empty name", ["--model", "alpha,,vmesh", *BAKE, "-o", os.path.join(bad, "{model}.vox")], ["commas"]),
    ("--param with several models", ["--model", "heitz-neyret,alpha", *BAKE, "--param", "edge_clear=0", "-o",
                                     os.path.join(bad, "{model}.vox")], ["--param", "one"]),
]
for what, args, words in cases:
    p = run(*args)
    err = p.stderr.strip()
    report(f"{what}: exit 1, one line saying why", p.returncode == 1 and "\n" not in err and all(w in err for w in words),
           f"rc {p.returncode}: {err}")
report("refused runs wrote nothing", os.listdir(bad) == [], str(os.listdir(bad)))

# ---------- a failed write leaves none of the run's files ----------
# vmesh's output path is a directory: alpha's file (written first) must be removed again.
fail = path("fail")
os.makedirs(os.path.join(fail, "vmesh.vox"), exist_ok=True)
p = run("--model", "alpha,vmesh", *BAKE, "-o", os.path.join(fail, "{model}.vox"))
report("a model's file that cannot be written: exit 1, naming it", p.returncode == 1 and "vmesh.vox" in p.stderr,
       p.stderr)
report("... and no other model's file is left", sorted(os.listdir(fail)) == ["vmesh.vox"], str(os.listdir(fail)))

# ---------- the dry run counts every model's records ----------
# (at 1024^3, so that the records show in the printed GiB)
one = run("--model", "alpha", "--res", "1024", "--dry-run", "-o", path("d_{model}.vox"))
both = run("--model", "alpha,vmesh", "--res", "1024", "--dry-run", "-o", path("d_{model}.vox"))


def records_gib(text):
    for line in text.splitlines():
        if "memory (estimate)" in line:
            return float(line.split("records")[1].split(",")[0])
    return None


report("dry run of two models: more record memory than one, nothing written",
       one.returncode == 0 and both.returncode == 0 and records_gib(both.stdout) > records_gib(one.stdout)
       and not any(n.startswith("d_") for n in os.listdir(TMP)), one.stdout + both.stdout)
finish()
