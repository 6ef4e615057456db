"""Declarations are checked against experiments/declaration.schema.json (python3-jsonschema) before
anything runs: the schema is a valid Draft 7 schema, every shipped declaration passes, and a bad field
stops `sweep.py --check` with status 2 and one line naming the file, the field, what was expected and
what was found; the checks a schema cannot state (scene files, scene subsets, counts, seeds) follow
it with the same kind of message. No voxlab job runs."""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, finish, report  # noqa: E402

SWEEP = os.path.join(REPO, "experiments", "sweep.py")
BASE = {"name": "t", "scenes": ["spheres"], "runs": [{"models": "all", "res": [8]}]}


def check(path):
    return subprocess.run([sys.executable, SWEEP, "--check", path], capture_output=True, text=True)


def main():
    from jsonschema import Draft7Validator

    with open(os.path.join(REPO, "experiments", "declaration.schema.json")) as f:
        schema = json.load(f)
    try:
        Draft7Validator.check_schema(schema)
        report("declaration.schema.json is a valid Draft 7 schema", True)
    except Exception as e:  # jsonschema.SchemaError
        report("declaration.schema.json is a valid Draft 7 schema", False, str(e)[:500])

    shipped = sorted(n for n in os.listdir(os.path.join(REPO, "experiments"))
                     if n.endswith(".json") and n != "declaration.schema.json")
    for n in shipped:
        p = check(os.path.join(REPO, "experiments", n))
        report(f"shipped {n} validates", p.returncode == 0, p.stderr[-400:])

    cases = [  # (name, fields replaced in BASE, field in the message, words of the message)
        ("res_type", {"runs": [{"res": [8, "big"]}]}, "runs[0].res[1]", 'expected an integer from 1 to 65536, got "big"'),
        ("res_float", {"runs": [{"res": [8.0]}]}, "runs[0].res[0]", "expected an integer from 1 to 65536, got 8.0"),
        ("unknown_field", {"runs": [{"res": [8], "resolution": [8]}]}, "runs[0].resolution", "unknown field (known:"),
        ("missing_res", {"runs": [{"spp": [1]}]}, "runs[0]", 'missing required field "res"'),
        ("size", {"runs": [{"res": [8], "size": [16, 0]}]}, "runs[0].size[1]", "expected an integer from 1 to 16384"),
        ("size_word", {"runs": [{"res": [8], "size": "big"}]}, "runs[0].size", 'expected "res", "scene", N or [W, H]'),
        ("bool", {"runs": [{"res": [8], "cache": [1]}]}, "runs[0].cache[0]", "expected true or false, got 1"),
        ("name", {"name": "a/b"}, "name", "expected a name"),
        ("nan", {"timeout_s": float("nan")}, "timeout_s", "expected a number >= 1, got NaN"),
        ("tolerance", {"tolerances": {"mse": {"better": "up"}}}, "tolerances.mse.better",
         'expected "lower" or "higher", got "up"'),
        ("variant", {"scenes": [{"base": "spheres", "vary": {"camera.fov_deg": []}}]}, "scenes[0].vary.camera.fov_deg",
         "expected a non-empty list of values"),
        ("top", None, "(top level)", "expected an object, got [1]"),
        # After the schema: what it cannot express.
        ("scene_file", {"scenes": ["no_such_scene"]}, "scenes[0]", "no_such_scene"),
        ("subset", {"runs": [{"res": [8], "scenes": ["bunny"]}]}, "runs[0].scenes[0]", "not one of the declared scenes"),
        ("curve_seed", {"seed": 3, "truth_curve": {"spp": [1], "seed": 3}}, "truth_curve.seed", "must differ"),
    ]
    for name, fields, where, what in cases:
        path = os.path.join(TMP, f"decl_{name}.json")
        os.makedirs(TMP, exist_ok=True)
        with open(path, "w") as f:
            json.dump([1] if fields is None else {**BASE, **fields}, f)
        p = check(path)
        line = p.stderr.strip()
        report(f"bad {name}: status 2, file, field and expectation",
               p.returncode == 2 and f"decl_{name}.json: {where}: " in line and what in line
               and "Traceback" not in p.stderr and len(line.splitlines()) == 1, line[-500:])


if __name__ == "__main__":
    main()
    finish()
