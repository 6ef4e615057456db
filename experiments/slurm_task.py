#!/usr/bin/python3
"""One SLURM array task of a sweep (executors.SlurmExecutor submits it):

    slurm_task.py BATCH_DIR        (index from $SLURM_ARRAY_TASK_ID)

Runs job spec number $SLURM_ARRAY_TASK_ID of BATCH_DIR/specs.json with jobexec.execute (outputs into
the shared cache) and writes BATCH_DIR/<index>.result.json: {"record": ...} or {"error": [message,
command, stderr]}, which the sweep gathers."""
import json
import os
import sys
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import jobexec  # noqa: E402


def main():
    d = sys.argv[1]
    i = int(os.environ["SLURM_ARRAY_TASK_ID"])
    with open(os.path.join(d, "specs.json")) as f:
        spec = json.load(f)[i]
    try:
        out = {"record": jobexec.execute(spec)}
    except jobexec.JobFailed as e:
        out = {"error": [str(a) for a in e.args]}
    except Exception as e:  # a broken image or stats file: still this job's failure
        out = {"error": [f"{type(e).__name__}: {e}", "", traceback.format_exc()]}
    tmp = os.path.join(d, f"{i}.result.json.tmp")
    with open(tmp, "w") as f:
        json.dump(out, f)
    os.replace(tmp, os.path.join(d, f"{i}.result.json"))


if __name__ == "__main__":
    main()
