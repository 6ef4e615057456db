"""The sweep on a cluster: the same tiny declaration (spheres at 16^3, two models, a 16-spp truth:
table1-sized, seven jobs) run by the local executor and by a real one, with separate caches; the rows
must be identical (every column but timings, dates, hosts and load) and so must the images, byte
for byte; every job must have run on that executor; and no job may have run while a timed job ran
(from the start and end times each job records).

    /usr/bin/python3 tests/test_cluster.py           a Dask scheduler and two workers on 127.0.0.1,
                                                     started here and torn down (part of make test)
    /usr/bin/python3 tests/test_cluster.py --slurm   a one-node SLURM cluster on localhost (munge,
                                                     slurmctld, slurmd; config written here, torn
                                                     down after): make test-slurm, as root
"""
import csv
import hashlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report  # noqa: E402

EXP = os.path.join(REPO, "experiments")
PY = "/usr/bin/python3"
# What differs between two runs of the same jobs: when, where, how fast, how loaded.
VOLATILE = {"render_s", "render_ms", "render_ms_min", "render_ms_spread", "bake_s", "bake_s_min", "bake_s_spread",
            "truth_s", "truth_s_min", "truth_s_spread", "load", "loaded", "peak_rss_bytes", "computed", "bvh_s",
            # Embree's allocator total: its parallel builder takes blocks per worker thread.
            "bvh_bytes",
            # Counters of the shading cache: per thread, so they vary with how the threads share the
            # pixels (a timed render uses every core); the images do not (compared byte for byte).
            "cache_hits", "model_evals"}
STARTED = []  # Popen objects of the daemons this test started, killed (their process groups) at the end


def declaration():
    path = os.path.join(TMP, "tiny.json")
    with open(path, "w") as f:
        json.dump({"name": "tiny", "truth_spp": 16, "scenes": ["spheres"], "repeats": 2,
                   "runs": [{"models": ["binary", "alpha"], "res": [16], "size": "res", "spp": [4]}]}, f)
    return path


def sweep(results, *extra, timeout=300):
    return subprocess.run([PY, os.path.join(EXP, "table1.py"), "--experiment", declaration(), "--results", results,
                           "--voxlab", VOXLAB, *extra], capture_output=True, text=True, timeout=timeout)


def rows(results):
    with open(os.path.join(results, "tiny", "rows.csv"), newline="") as f:
        return [{k: v for k, v in r.items() if k not in VOLATILE} for r in csv.DictReader(f)]


def images(results):
    """sha256 of every image's pixels the rows name, by the row's column (the pixels: an EXR's header
    also holds its provenance, the command line with the job's own staging folder)."""
    out = {}
    for r in rows(results):
        for col in ("image", "truth_image"):
            out[(r["model"], col)] = hashlib.sha256(read_image(os.path.join(results, r[col])).tobytes()).hexdigest()
    return out


def records(results):
    recs = []
    for kind in ("truth", "bake", "render", "compare"):
        d = os.path.join(results, "cache", kind)
        for n in os.listdir(d) if os.path.isdir(d) else []:
            p = os.path.join(d, n, "job.json")
            if os.path.isfile(p):
                with open(p) as f:
                    recs.append(json.load(f))
    return recs


def overlaps(recs):
    """Pairs (timed job, other job) whose run times overlap. Bakes of one pass of the sampler (each
    names the others in baked_with) are one voxlab run, not jobs beside each other."""
    out = []
    for a in recs:
        if not a.get("timed"):
            continue
        for b in recs:
            if b is a or b["label"] in a.get("baked_with", []):
                continue
            if b["started_at"] < a["finished_at"] and a["started_at"] < b["finished_at"]:
                out.append((a["label"], b["label"]))
    return out


def check_same(name, local, other, executor):
    p_rows, o_rows = rows(local), rows(other)
    report(f"{name}: rows identical to the local executor's", p_rows == o_rows and len(p_rows) == 2,
           f"local {p_rows}\n{name} {o_rows}")
    report(f"{name}: images identical (sha256 of the pixels)", images(local) == images(other), "")
    recs = records(other)
    report(f"{name}: every job ran on the {executor} executor", len(recs) == 7 and
           all(r.get("executor") == executor for r in recs), str([(r["label"], r.get("executor")) for r in recs]))
    report(f"{name}: no job ran beside a timed job", not overlaps(recs), str(overlaps(recs)[:4]))
    timed = [r for r in recs if r["timed"] and r["kind"] != "bake"]
    report(f"{name}: timed jobs repeated as declared", timed and all(len(r["timing"]["runs"]) == 2 for r in timed),
           str([(r["label"], r.get("timing")) for r in timed]))


def start(cmd, log):
    p = subprocess.Popen(cmd, stdout=open(log, "w"), stderr=subprocess.STDOUT, start_new_session=True)
    STARTED.append(p)
    return p


def stop_all():
    for p in reversed(STARTED):
        try:
            os.killpg(p.pid, signal.SIGTERM)
        except OSError:
            pass
    deadline = time.monotonic() + 10
    for p in reversed(STARTED):
        try:
            p.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except OSError:
                pass
            p.wait()
    STARTED.clear()


def wait_for(cond, seconds):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.3)
    return False


def dask_part(local):
    d = os.path.join(TMP, "dask")
    os.makedirs(d, exist_ok=True)
    sched_file = os.path.join(d, "scheduler.json")
    start(["dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file",
           sched_file], os.path.join(d, "scheduler.log"))
    ok = wait_for(lambda: os.path.exists(sched_file), 60)
    report("dask scheduler starts on 127.0.0.1", ok, "no scheduler file after 60 s")
    if not ok:
        return
    with open(sched_file) as f:
        address = json.load(f)["address"]
    for i in range(2):
        start(["dask", "worker", "--scheduler-file", sched_file, "--host", "127.0.0.1", "--nthreads", "1",
               "--no-dashboard", "--memory-limit", "0", "--name", f"w{i}", "--local-directory", d],
              os.path.join(d, f"worker{i}.log"))
    from distributed import Client

    with Client(address, timeout=30) as c:
        ok = wait_for(lambda: len(c.scheduler_info()["workers"]) == 2, 60)
    report("two dask workers connect", ok and address.startswith("tcp://127.0.0.1:"), address)
    if not ok:
        return
    results = os.path.join(TMP, "dask-results")
    p = sweep(results, "--executor", "dask", "--scheduler", address)
    report("sweep through the dask scheduler exits 0", p.returncode == 0, p.stderr[-1500:])
    if p.returncode == 0:
        check_same("dask", local, results, "dask")
    p = sweep(os.path.join(TMP, "no-scheduler"), "--executor", "dask", "--scheduler", "tcp://127.0.0.1:9",
              timeout=120)
    report("an unreachable scheduler is a clear error", p.returncode == 1 and "cannot connect" in p.stderr and
           "Traceback" not in p.stderr, p.stderr[-600:])


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


SLURM_CONF = """ClusterName=voxlabtest
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={ctld}
SlurmdPort={slurmd}
AuthType=auth/munge
AuthInfo=socket={sock}
CryptoType=crypto/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
ReturnToService=2
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
SlurmdSpoolDir={d}/slurmd
StateSaveLocation={d}/state
SlurmUser=root
SlurmdUser=root
SwitchType=switch/none
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
SlurmctldLogFile={d}/slurmctld.log
SlurmdLogFile={d}/slurmd.log
MinJobAge=300
NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN
PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
"""


def slurm_part(local):
    for tool in ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "scontrol"):
        if not shutil.which(tool):
            report(f"{tool} installed (apt-get install slurm-wlm munge)", False, "")
            return
    d = os.path.join(TMP, "slurm")
    for sub in ("slurmd", "state", "munge"):
        os.makedirs(os.path.join(d, sub), exist_ok=True)
    os.chmod(os.path.join(d, "munge"), 0o700)
    key = os.path.join(d, "munge", "munge.key")
    with open(key, "wb") as f:
        f.write(os.urandom(1024))
    os.chmod(key, 0o400)
    sock = os.path.join(d, "munge", "munge.socket")
    start(["munged", "-F", "--key-file", key, "--socket", sock, "--pid-file", os.path.join(d, "munge", "munged.pid"),
           "--log-file", os.path.join(d, "munge", "munged.log"), "--seed-file", os.path.join(d, "munge", "seed"),
           "--force"], os.path.join(d, "munged.out"))
    ok = wait_for(lambda: os.path.exists(sock), 20)
    report("munged starts", ok, open(os.path.join(d, "munged.out")).read()[-500:])
    if not ok:
        return
    host = socket.gethostname().split(".")[0]
    conf = os.path.join(d, "slurm.conf")
    with open(conf, "w") as f:
        f.write(SLURM_CONF.format(host=host, ctld=free_port(), slurmd=free_port(), d=d, cpus=os.cpu_count(), sock=sock))
    env = {**os.environ, "SLURM_CONF": conf}
    os.environ["SLURM_CONF"] = conf  # sbatch and squeue, run by the sweep, read it
    # munge's clients find the daemon's socket through this (the slurm plugins use libmunge).
    munge_env = {"MUNGE_SOCKET": sock}
    os.environ.update(munge_env)
    env.update(munge_env)
    start(["slurmctld", "-D", "-i", "-f", conf], os.path.join(d, "slurmctld.out"))
    start(["slurmd", "-D", "-f", conf, "-N", host], os.path.join(d, "slurmd.out"))

    def idle():
        p = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True, env=env)
        return p.returncode == 0 and p.stdout.strip() in ("idle", "mixed")

    ok = wait_for(lambda: idle() or any(p.poll() is not None for p in STARTED), 60) and idle()
    report("one-node SLURM cluster comes up (sinfo: idle)", ok,
           "".join(open(os.path.join(d, n)).read()[-600:] for n in ("slurmctld.out", "slurmd.out")))
    if not ok:
        return
    results = os.path.join(TMP, "slurm-results")
    t0 = time.monotonic()
    p = sweep(results, "--executor", "slurm", "--slurm-args=--time=10", timeout=600)
    print(f"# slurm sweep took {time.monotonic() - t0:.1f} s; its stderr:\n# " + p.stderr.strip().replace("\n", "\n# "))
    report("sweep through SLURM job arrays exits 0", p.returncode == 0, p.stderr[-1500:])
    if p.returncode == 0:
        check_same("slurm", local, results, "slurm")


def main():
    local = os.path.join(TMP, "local-results")
    p = sweep(local, "--jobs", "2")
    report("local sweep exits 0", p.returncode == 0, p.stderr[-1500:])
    if p.returncode != 0:
        return
    recs = records(local)
    report("local: no job ran beside a timed job", len(recs) == 7 and not overlaps(recs), str(overlaps(recs)[:4]))
    try:
        if "--slurm" in sys.argv:
            slurm_part(local)
        else:
            dask_part(local)
    finally:
        stop_all()


if __name__ == "__main__":
    main()
    finish()
