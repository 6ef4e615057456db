"""Running voxlab: one call with its output, the registered models, and the measured job runner.

Exists to keep subprocess handling in one place. The sweep's jobs (GNU time, process groups,
timeouts, repeats) run through jobexec.py, which every executor calls on whatever machine runs the
job; this module re-exports its pieces for the scripts and adds the short calls (`voxlab models`).
"""
import re
import subprocess

import jobexec

from .errors import VoxlabError



def run_voxlab(voxlab, args):
    """Runs voxlab; returns stdout, or raises VoxlabError with the command and its stderr."""
    cmd = [voxlab, *map(str, args)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:  # no binary (not built yet) or not executable: one line, not a traceback
        raise VoxlabError(f"cannot run {voxlab}: {e.strerror} (build it with make)")
    if p.returncode != 0:
        raise VoxlabError(f"`{' '.join(cmd)}` exited with status {p.returncode}:\n{p.stderr.rstrip()}")
    return p.stdout


# Running a job (GNU time, process groups, timeouts) lives in jobexec, which every executor calls.
GNU_TIME = jobexec.GNU_TIME
run_measured = jobexec.run_measured
kill_running = jobexec.kill_running


def models_info(voxlab):
    """`voxlab models`: [{name, bytes_per_voxel, rule, description}] in registry order."""
    out = []
    for line in run_voxlab(voxlab, ["models"]).splitlines():
        if not line.strip():
            continue
        m = re.match(r"(\S+)\s+(\d+)\s+B/voxel\s+(\S+)\s+(.*)", line)
        if m:
            out.append({"name": m[1], "bytes_per_voxel": int(m[2]), "rule": m[3], "description": m[4].strip()})
        else:  # a format we do not know yet: the name is still the first word
            out.append({"name": line.split()[0], "bytes_per_voxel": None, "rule": "", "description": line})
    return out


def list_models(voxlab):
    return [line.split()[0] for line in run_voxlab(voxlab, ["models"]).splitlines() if line.strip()]


def metric_names(voxlab):
    """The keys `voxlab compare --json` writes for its metrics, in its order (`compare --list-metrics`:
    one table in voxlab's cmd_compare.c). The rows, the history and the baseline take their metric
    columns from here, so adding a metric is one edit in C."""
    names = [line.strip() for line in run_voxlab(voxlab, ["compare", "--list-metrics"]).splitlines() if line.strip()]
    if not names:
        raise VoxlabError(f"`{voxlab} compare --list-metrics` listed no metric")
    return names
