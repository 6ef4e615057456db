"""Where a sweep's jobs run: this machine's threads, a Dask cluster, or a SLURM cluster.

    make_executor("local" | "dask" | "slurm", jobs=2, scheduler="tcp://host:8786", slurm_args="...")

The sweep (voxlab_exp.scheduler.Sweep.run) decides what is ready and where it may go; an executor only
starts job specs (see jobexec.py) and reports them finished. Every executor runs the same
jobexec.execute on the same spec, and the worker writes its outputs into the shared cache directory,
so rows are the same whatever the executor (the cache folder must be the same path on every
machine: a shared file system).

Timed jobs are never co-scheduled with anything. Local and Dask: the sweep places jobs on hosts
(`places()`: host -> slots) and starts a timed job only on a host where nothing runs, and nothing on
that host until it ends (two Dask workers on one host are one place). SLURM does this itself:
timed jobs go into an array submitted with `--exclusive` (a node to themselves), the others into
an array that may share nodes.
"""
import concurrent.futures as cf
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

import dask_task
import jobexec

HERE = os.path.dirname(os.path.abspath(__file__))


class ExecutorError(Exception):
    pass


class LocalExecutor:
    """A thread pool on this machine: `jobs` jobs at a time."""

    name = "local"
    exclusive_by_sweep = True

    def __init__(self, jobs=2):
        self.jobs = max(1, jobs)
        self.pool = cf.ThreadPoolExecutor(max_workers=self.jobs)

    def places(self):
        return {"localhost": self.jobs}

    def submit(self, spec, place):
        return self.pool.submit(jobexec.execute, spec)

    def wait(self, futures):
        """The futures that are done (at least one); each gives .result() -> record or raises."""
        done, _ = cf.wait(futures, return_when=cf.FIRST_COMPLETED)
        return done

    def close(self):
        self.pool.shutdown(wait=True, cancel_futures=True)


class DaskExecutor:
    """Jobs as tasks on a running Dask distributed scheduler (`dask scheduler`, `dask worker`).

    Each worker thread is a slot; workers are grouped by host, and a job is pinned to the workers of
    the host the sweep placed it on. The task (dask_task.run) travels to the workers by value and
    imports jobexec from this checkout's experiments/, so a worker needs only Python 3 with numpy,
    OpenImageIO and PIL, and this checkout, the cache (voxlab's snapshot among it) and the scene files
    under the same paths (a shared file system)."""

    name = "dask"
    exclusive_by_sweep = True

    def __init__(self, scheduler, timeout=30):
        if not scheduler:
            raise ExecutorError("--executor dask needs --scheduler tcp://HOST:PORT (a running `dask scheduler`)")
        try:
            import cloudpickle
            from distributed import Client
        except ImportError as e:
            raise ExecutorError(f"--executor dask: {e} (Debian: apt-get install python3-distributed)")
        cloudpickle.register_pickle_by_value(dask_task)
        try:
            self.client = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as e:
            raise ExecutorError(f"--scheduler {scheduler}: cannot connect: {e}")
        workers = self.client.scheduler_info()["workers"]
        if not workers:
            raise ExecutorError(f"--scheduler {scheduler}: no worker is connected")
        self.hosts = {}
        for addr, w in workers.items():
            h = self.hosts.setdefault(w["host"], {"workers": [], "slots": 0})
            h["workers"].append(addr)
            h["slots"] += w.get("nthreads", 1)

    def places(self):
        return {h: v["slots"] for h, v in self.hosts.items()}

    def submit(self, spec, place):
        return self.client.submit(dask_task.run, spec, HERE, key=f"voxlab-{spec['kind']}-{spec['key'][:16]}-{time.time()}",
                                  workers=self.hosts[place]["workers"], allow_other_workers=False, pure=False)

    def wait(self, futures):
        from distributed import wait

        done, _ = wait(list(futures), return_when="FIRST_COMPLETED")
        return done

    def close(self):
        self.client.close()


class _SlurmFuture:
    def __init__(self, spec, result_path, array_id):
        self.spec, self.result_path, self.array_id = spec, result_path, array_id
        self._outcome = None

    def done(self):
        return self._outcome is not None

    def result(self):
        ok, value = self._outcome
        if ok:
            return value
        raise jobexec.JobFailed(*value)


class SlurmExecutor:
    """SLURM job arrays: every batch of ready jobs becomes one `sbatch --array` (timed jobs in an
    array of their own with --exclusive), one array task per job. A task runs
    experiments/slurm_task.py, which runs jobexec.execute for its index and writes the record (or
    the failure) beside the batch; the sweep gathers them, and the outputs are in the cache.
    `slurm_args` (e.g. "--partition=gpu --time=02:00:00") are passed to every sbatch."""

    name = "slurm"
    exclusive_by_sweep = False

    def __init__(self, cache_dir, slurm_args="", poll=1.0):
        if not shutil.which("sbatch"):
            raise ExecutorError("--executor slurm: no sbatch on PATH (Debian: apt-get install slurm-client)")
        self.batch_root = os.path.join(cache_dir, "slurm")
        os.makedirs(self.batch_root, exist_ok=True)
        self.args = shlex.split(slurm_args or "")
        self.poll = poll
        self.waiting = []  # futures not yet done

    def places(self):
        return {"slurm": 1 << 30}  # SLURM queues and places; the sweep submits whatever is ready

    def submit_batch(self, specs, exclusive):
        d = tempfile.mkdtemp(prefix="batch-", dir=self.batch_root)
        with open(os.path.join(d, "specs.json"), "w") as f:
            json.dump(specs, f)
        cmd = ["sbatch", "--parsable", f"--array=0-{len(specs) - 1}", f"--job-name=voxlab-{specs[0]['kind']}",
               f"--output={d}/slurm-%A_%a.out", *(["--exclusive"] if exclusive else []), *self.args,
               "--wrap", f"{shlex.quote(sys.executable)} {shlex.quote(os.path.join(HERE, 'slurm_task.py'))} "
                         f"{shlex.quote(d)}"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            raise ExecutorError(f"`{' '.join(cmd)}` failed: {p.stderr.strip()}")
        array_id = p.stdout.strip().split(";")[0]
        futs = [_SlurmFuture(s, os.path.join(d, f"{i}.result.json"), array_id) for i, s in enumerate(specs)]
        self.waiting += futs
        return futs

    def _array_alive(self, array_id):
        p = subprocess.run(["squeue", "-h", "-j", array_id, "-o", "%i"], capture_output=True, text=True)
        if p.returncode != 0:  # a job purged from the controller is "invalid"; anything else: ask again
            return "Invalid job id" not in p.stderr
        return p.stdout.strip() != ""

    def wait(self, futures):
        while True:
            done = []
            for f in list(futures):
                if f.done():
                    done.append(f)
                    continue
                if os.path.exists(f.result_path):
                    with open(f.result_path) as fh:
                        r = json.load(fh)
                    f._outcome = (True, r["record"]) if "record" in r else (False, tuple(r["error"]))
                    done.append(f)
                elif not self._array_alive(f.array_id) and not os.path.exists(f.result_path):
                    f._outcome = (False, (f"SLURM task {f.array_id} ended without a result (see "
                                          f"{os.path.dirname(f.result_path)}/slurm-*.out)", "", ""))
                    done.append(f)
            if done:
                return done
            time.sleep(self.poll)

    def close(self):
        pass


def make_executor(name, jobs=2, scheduler=None, slurm_args="", cache_dir=None):
    if name == "local":
        return LocalExecutor(jobs)
    if name == "dask":
        return DaskExecutor(scheduler)
    if name == "slurm":
        return SlurmExecutor(cache_dir, slurm_args)
    raise ExecutorError(f"--executor {name}: expected local, dask or slurm")
