"""What a Dask worker runs for one sweep job (executors.DaskExecutor submits it).

Shipped to the workers by value (cloudpickle), so a worker needs no PYTHONPATH: it imports jobexec
from the experiments/ folder the client names, which every worker sees under the same path (a
shared file system, as for the cache). jobexec itself is imported, not shipped: it holds locks and
the set of running children, which are per process."""


def run(spec, experiments_dir):
    import sys

    if experiments_dir not in sys.path:
        sys.path.insert(0, experiments_dir)
    import jobexec

    return jobexec.execute(spec)
