"""Where and what we ran on: git commit and dirtiness, the machine, the date.

Exists because every table, row file and baseline states these, and they must be described the
same way everywhere (the history and the baseline compare commits).
"""
import datetime
import os
import platform
import subprocess

from .config import REPO



def git_commit():
    try:
        head = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True, text=True, check=True)
        # results/ is left out: runs append to results/history.csv, which must not make the next
        # run's checkout count as modified.
        dirty = subprocess.run(["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no", "--", ".",
                                ":(exclude)results"], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return head.stdout.strip() + (" (with uncommitted changes)" if dirty.stdout.strip() else "")


def git_info():
    """{"commit": 40 hex or "unknown", "dirty": bool}: tracked files differing from HEAD make it dirty."""
    s = git_commit()
    if s.startswith("unknown"):
        return {"commit": "unknown", "dirty": False, "text": s}
    return {"commit": s.split()[0], "dirty": "uncommitted" in s, "text": s}


def machine_info():
    u = platform.uname()
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
            mem = f"{kb / 2**20:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return {"host": u.node, "system": f"{u.system} {u.release} {u.machine}", "cpu": cpu, "nproc": os.cpu_count(),
            "memory": mem}


def machine_text(m):
    return f"{m['cpu'] or 'unknown CPU'}, {m['nproc']} cores, {m['memory']} RAM, {m['system']} (host {m['host']})"


def now_iso():
    return datetime.datetime.now().astimezone().isoformat(timespec="seconds")
