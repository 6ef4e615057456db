"""Files written whole or not at all: atomic writes of text, JSON, CSV, PNG and matplotlib figures.

Exists because several sweeps, the dashboard and colleagues' runs share results/: every output is
written under a temporary name beside its destination and renamed, so a killed run never leaves a
half-written file that looks complete.
"""
import json
import os
import threading



def atomic_write(path, write):
    """Calls write(tmp) for a temporary name next to path (same file system), then renames."""
    tmp = f"{path}.tmp.{os.getpid()}.{threading.get_ident()}"
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_text(path, text):
    def w(tmp):
        with open(tmp, "w", newline="") as f:
            f.write(text)

    atomic_write(path, w)


def write_json(path, obj):
    write_text(path, json.dumps(obj, indent=1, sort_keys=False, allow_nan=False, default=str) + "\n")


def save_png(img, path):
    atomic_write(path, lambda tmp: img.save(tmp, format="PNG"))


def save_figure(fig, path, **kw):
    """matplotlib figures too are written under a temporary name (format from path's extension)."""
    fmt = os.path.splitext(path)[1][1:]
    atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt, **kw))


def csv_text(rows, fields):
    """rows (dicts) as CSV with exactly the columns `fields` (other keys ignored, missing ones empty),
    through a pandas frame of Python objects: ints stay ints, floats keep every digit (repr: they
    round-trip to the double voxlab printed), None is an empty cell."""
    import pandas as pd

    frame = pd.DataFrame([[r.get(k) for k in fields] for r in rows], columns=fields, dtype=object)
    frame = frame.applymap(lambda v: "" if v is None else repr(v) if isinstance(v, float) else v)
    return frame.to_csv(index=False, lineterminator="\n")


def write_csv(path, rows, fields):
    write_text(path, csv_text(rows, fields))


def load_json(path):
    with open(path) as f:
        return json.load(f)


def rel(path, root):
    """path relative to root when it lies under root, else absolute (row paths are relative to results/)."""
    path = os.path.abspath(path)
    root = os.path.abspath(root)
    return os.path.relpath(path, root) if path.startswith(root + os.sep) else path
