"""voxlab's experiment engine, one module per job (see experiments/README.md, "Module map").

    config      where the checkout and results are; defaults
    errors      VoxlabError (exit 1) and DeclarationError (exit 2)
    files       atomic writes: text, JSON, CSV (through pandas), PNG, figures
    hashing     content hashes of files and of JSON objects
    jobs        running voxlab: one call, its models and metric names, the measured runner (jobexec)
    images      EXR reading, sRGB previews, error maps, labelled strips
    provenance  git commit, machine, date
    scenes      scene files: lookup, fingerprints, variants
    schema      declarations: JSON Schema (declaration.schema.json) + the checks it cannot express
    scheduler   jobs, cache entries, executors, progress: the sweep
    rows        declaration -> jobs -> rows.csv / rows.json
    history     results/history.csv and the baseline comparison
    report      the settings lines every table states
    cli         the scripts' shared options and exit statuses

The scripts in experiments/ put that folder on sys.path and import from here, e.g.
`from voxlab_exp.rows import run_experiment`. The executors' worker side (jobexec.py, dask_task.py,
slurm_task.py) stays outside the package: workers import it by file from the checkout.
"""
import os
import sys

# jobexec, executors and code_keys live beside the package in experiments/.
_HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)
