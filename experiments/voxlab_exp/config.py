"""Where things are: the checkout, the results root, voxlab, the interpreter and the default seed.

Exists so that every module and script names these once (the package lives in experiments/voxlab_exp/,
the checkout is two folders up).
"""
import os

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SEED = 1
DEFAULT_RESULTS = os.path.join(REPO, "results")
DEFAULT_VOXLAB = os.path.join(REPO, "build", "voxlab")
PYTHON = "/usr/bin/python3"
