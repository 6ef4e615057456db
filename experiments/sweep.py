#!/usr/bin/python3
"""Runs one declared experiment (experiments/*.json) and writes its rows.

    /usr/bin/python3 experiments/sweep.py experiments/table1.json [--results results] [--cache DIR]
        [--jobs 2] [--voxlab build/voxlab] [--force] [--repeats R] [--executor local|dask|slurm]
        [--scheduler tcp://HOST:PORT] [--slurm-args ARGS] [--out DIR] [--check]

Writes <out> (default <results>/<name>/): rows.csv and rows.json, one row per configuration (scene x
model x resolution x parameters) with MSE, SSIM, timings and memory, or status "failed" and voxlab's
message; rows.json also holds the run's machine, commit, date, binary hash and settings. Every voxlab
job is cached under <cache> (default <results>/cache) by the hash of its inputs. --check only
validates the declaration. Exit status: 0 (even when some configurations failed: they are in the
rows), 1 when the sweep could not run at all, 2 for a bad declaration.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper, sweep_args  # noqa: E402
from voxlab_exp.rows import run_experiment  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("declaration", help="experiment declaration (JSON)")
    add_common_args(ap)
    ap.add_argument("--out", help="output directory (default <results>/<name>)")
    ap.add_argument("--check", action="store_true", help="only validate the declaration")
    a = ap.parse_args(argv)

    def go():
        decl = load_declaration(a.declaration, a.voxlab)
        if a.check:
            print(f"{decl['shown']}: ok ({len(decl['scenes'])} scene(s), {len(decl['runs'])} run(s))")
            return 0
        run_experiment(decl, **sweep_args(a), out_dir=a.out)
        return 0

    return main_wrapper(go, "sweep")


if __name__ == "__main__":
    sys.exit(main())
