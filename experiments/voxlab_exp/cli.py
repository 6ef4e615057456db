"""Command-line plumbing every experiment script shares: common options, exit statuses.

Exists so that table1.py, pareto.py, figures.py, regress.py, sweep.py and demo.py take the same
options (--jobs, --voxlab, --executor, ...) and fail the same way: a bad declaration exits 2 and
any other voxlab or executor error 1, each with one clear line.
"""
import os
import sys

import executors

from .config import DEFAULT_RESULTS, REPO
from .errors import DeclarationError, VoxlabError
from .rows import run_experiment
from .schema import load_declaration



def add_common_args(ap, experiment=None):
    ap.add_argument("--experiment", default=experiment, help="declaration (default %(default)s)")
    ap.add_argument("--results", default=DEFAULT_RESULTS, help="results root (default results/)")
    ap.add_argument("--cache", help="job cache (default <results>/cache)")
    ap.add_argument("--jobs", type=int, default=2, help="untimed jobs at a time on this machine (default 2)")
    ap.add_argument("--voxlab", default=os.path.join(REPO, "build", "voxlab"), help="voxlab binary")
    ap.add_argument("--force", "--fresh", dest="fresh", action="store_true",
                    help="recompute every job (fresh timings), replacing its cache entry")
    ap.add_argument("--repeats", type=int, help="timed runs per timed job (default: the declaration's, else 5)")
    ap.add_argument("--executor", choices=["local", "dask", "slurm"], default="local",
                    help="where jobs run: this machine (default), a Dask scheduler, a SLURM cluster")
    ap.add_argument("--scheduler", help="--executor dask: the scheduler's address, tcp://HOST:PORT")
    ap.add_argument("--slurm-args", default="", help="--executor slurm: extra sbatch options, one string")
    ap.add_argument("--separate-bakes", action="store_true",
                    help="bake each model in its own voxlab run (its bake time measured alone) instead of the "
                         "models of one scene, resolution, rays and seed in one pass of the sampler (each "
                         "model's time estimated from its part of the pass)")


def sweep_args(a):
    """run_experiment's keyword arguments from add_common_args' options."""
    return {"results": a.results, "cache_dir": a.cache, "voxlab": a.voxlab, "jobs": a.jobs, "fresh": a.fresh,
            "executor": a.executor, "scheduler": a.scheduler, "slurm_args": a.slurm_args, "repeats": a.repeats,
            "group_bakes": not getattr(a, "separate_bakes", False)}


def experiment_from_args(a, **kw):
    decl = load_declaration(a.experiment, a.voxlab)
    return run_experiment(decl, **sweep_args(a), **kw)


def main_wrapper(fn, prog):
    """Runs fn(); a DeclarationError exits 2 and any other VoxlabError 1, each with one clear line."""
    try:
        return fn()
    except DeclarationError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except (VoxlabError, executors.ExecutorError) as e:
        print(f"{prog}: error: {e.args[0]}", file=sys.stderr)
        return 1
