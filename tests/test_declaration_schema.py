"""Declarations are checked against experiments/declaration.schema.json (python3-jsonschema) before
anything runs: the schema is a valid Draft 7 schema, every shipped declaration passes, and a bad field
stops `sweep.py --check` with status 2 and one line naming the file, the field, what was expected and
what was found; the checks a schema cannot state (scene files, scene subsets, counts, seeds, keys
given twice, pixel counts) follow it with the same kind of message, and so do the two that ask voxlab
(scene variants through its scene parser, tolerance names against its metrics). The schema's ranges
are voxlab's own, read here from voxlab's messages. No voxlab job runs."""
import json
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, report, voxlab  # noqa: E402

SWEEP = os.path.join(REPO, "experiments", "sweep.py")
BASE = {"name": "t", "scenes": ["spheres"], "runs": [{"models": "all", "res": [8]}]}


def check(path, *extra):
    return subprocess.run([sys.executable, SWEEP, "--voxlab", VOXLAB, *extra, path], capture_output=True, text=True)


def check_only(path):
    return check(path, "--check")


def refusal_range(*args):
    """(lo, hi) from voxlab's refusal of an option's value: "expected an integer from LO to HI"."""
    p = voxlab(*args, check=False)
    m = re.search(r"expected an integer from (-?\d+) to (\d+)", p.stderr)
    return (int(m[1]), int(m[2])) if p.returncode != 0 and m else p.stderr[-300:]


def schema_range(schema, *path):
    """(minimum, maximum) of a schema entry, following "items" and "$ref" along the path."""
    node = schema
    for k in path:
        node = node[k]
        while "$ref" in node:
            node = schema["definitions"][node["$ref"].split("/")[-1]]
    return node.get("minimum"), node.get("maximum")


def limits_match_voxlab(schema):
    """Every range the schema gives an option of voxlab's is the one voxlab's own parser takes, so a
    declaration that passes --check is never refused by a job (and a limit changed in C fails here)."""
    scene, vox, exr = os.path.join(REPO, "scenes", "spheres.json"), os.path.join(TMP, "x.vox"), os.path.join(TMP, "x.exr")
    bake = ["bake", scene, "--model", "x", "-o", vox]
    render = ["render", scene, "--model", "x", "--res", "8", "-o", exr]
    truth = ["truth", scene, "--dry-run", "-o", exr]
    pairs = [  # (schema path, voxlab's command that takes it, its option)
        (("properties", "seed"), truth, "--seed"), (("properties", "seed"), bake, "--seed"),
        (("properties", "seed"), render, "--seed"),
        (("properties", "truth_curve", "properties", "seed"), truth, "--seed"),
        (("definitions", "run", "properties", "res", "items"), bake, "--res"),
        (("definitions", "run", "properties", "res", "items"), render, "--res"),
        (("definitions", "run", "properties", "spp", "items"), render, "--spp"),
        (("definitions", "run", "properties", "rays", "items"), bake, "--rays"),
        (("properties", "truth_spp"), truth, "--spp"),
        (("definitions", "list_spp_curve", "items"), truth, "--spp"),
    ]
    for path, cmd, opt in pairs:
        theirs = refusal_range(*cmd, opt, "x")
        ours = schema_range(schema, *path)
        report(f"schema {'.'.join(path[1::2])} is voxlab {cmd[0]} {opt}'s range", ours == theirs,
               f"schema {ours}, voxlab {theirs}")
    # Image sizes: each side and the pixel count (voxlab's --size message names both).
    p = voxlab(*truth, "--size", "0x0", check=False)
    m = re.search(r"integers from 1 to (\d+) \(at most (\d+) pixels\)", p.stderr)
    ours = (schema_range(schema, "definitions", "dim")[1], schema.get("x-max-pixels"))
    report("schema image side and x-max-pixels are voxlab's --size limits",
           bool(m) and ours == (int(m[1]), int(m[2])), f"schema {ours}, voxlab: {p.stderr[-300:]}")


def write(name, decl):
    path = os.path.join(TMP, f"decl_{name}.json")
    with open(path, "w") as f:
        f.write(decl if isinstance(decl, str) else json.dumps(decl))
    return path


def main():
    from jsonschema import Draft7Validator

    with open(os.path.join(REPO, "experiments", "declaration.schema.json")) as f:
        schema = json.load(f)
    try:
        Draft7Validator.check_schema(schema)
        report("declaration.schema.json is a valid Draft 7 schema", True)
    except Exception as e:  # jsonschema.SchemaError
        report("declaration.schema.json is a valid Draft 7 schema", False, str(e)[:500])

    limits_match_voxlab(schema)

    shipped = sorted(n for n in os.listdir(os.path.join(REPO, "experiments"))
                     if n.endswith(".json") and n != "declaration.schema.json")
    for n in shipped:
        p = check_only(os.path.join(REPO, "experiments", n))
        report(f"shipped {n} validates", p.returncode == 0, p.stderr[-400:])

    cases = [  # (name, fields replaced in BASE, field in the message, words of the message)
        ("res_type", {"runs": [{"res": [8, "big"]}]}, "runs[0].res[1]", 'expected an integer from 1 to 1024, got "big"'),
        ("res_float", {"runs": [{"res": [8.0]}]}, "runs[0].res[0]", "expected an integer from 1 to 1024, got 8.0"),
        # voxlab's own limits (they passed --check once, and every job then failed).
        ("res_limit", {"runs": [{"res": [2000]}]}, "runs[0].res[0]", "expected an integer from 1 to 1024, got 2000"),
        ("seed_limit", {"seed": 2 ** 80}, "seed", "expected an integer from 0 to 2^53, got 1208925819614629174706176"),
        ("curve_seed_limit", {"truth_curve": {"spp": [1], "seed": 2 ** 53 + 1}}, "truth_curve.seed",
         "expected an integer from 0 to 2^53"),
        ("curve_seed_default", {"seed": 2 ** 53, "truth_curve": {"spp": [1]}}, "truth_curve",
         "defaults to seed + 1 = 9007199254740993"),
        ("pixels_wh", {"runs": [{"res": [8], "size": [16384, 16384]}]}, "runs[0].size",
         "expected at most 67108864 pixels (voxlab's limit), got [16384, 16384] (268435456 pixels)"),
        ("pixels_n", {"runs": [{"res": [8], "size": 8193}]}, "runs[0].size", "expected at most 67108864 pixels"),
        ("pixels_curve", {"truth_curve": {"spp": [1], "size": [16384, 4097]}}, "truth_curve.size",
         "expected at most 67108864 pixels"),
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
        # Scene variants, applied to their scene and read by voxlab's scene parser before any job.
        ("variant_type", {"scenes": [{"base": "spheres", "name": "v", "set": {"camera.fov_deg": "wide"}}]},
         "scenes[0].set.camera.fov_deg", 'scene variant "v": camera.fov_deg: expected a finite number'),
        ("variant_field", {"scenes": [{"base": "spheres", "name": "v", "set": {"camera.nope.x": 1}}]},
         "scenes[0].set.camera.nope.x", 'scene variant "v": camera: unknown field "nope"'),
        ("variant_index", {"scenes": [{"base": "spheres", "name": "v", "set": {"lights.5.irradiance": [1, 1, 1]}}]},
         "scenes[0].set.lights.5.irradiance", 'scene variant "v": lights.5.irradiance: 5 is not an index of a list of 1'),
        ("variant_vary", {"scenes": ["spheres", {"base": "trees", "name": "f",
                                                 "vary": {"objects.0.params.count": [2, "many"]}}]},
         "scenes[1].vary.objects.0.params.count", 'scene variant "f_countmany": objects[0].params.count: expected'),
        ("variant_size", {"scenes": [{"base": "spheres", "name": "v", "set": {"size": [16384, 16384]}}]},
         "scenes[0].set.size", "at most 67108864 pixels"),
        # A tolerance must name a column the baseline has: voxlab's metrics or the times and memory.
        ("tolerance_name", {"tolerances": {"nope": {"better": "lower"}}}, "tolerances.nope",
         "unknown metric (known: mse, psnr, ssim, render_ms, bake_s, mb, bytes_per_voxel)"),
        # A key given twice: JSON keeps the last without a word (raw text, as json.dumps cannot write it).
        ("twice_top", '{"name": "t", "seed": 1, "scenes": ["spheres"], "runs": [{"res": [8]}], "seed": 2}', "seed",
         "given twice"),
        ("twice_run", '{"name": "t", "scenes": ["spheres"], "runs": [{"res": [8], "spp": [1], "res": [16]}]}',
         "runs[0].res", "given twice"),
    ]
    # Plain scene files are read by voxlab's scene parser too (a file it refuses failed every job).
    with open(os.path.join(REPO, "scenes", "spheres.json")) as f:
        spheres = json.load(f)
    with open(os.path.join(TMP, "scene_unknown.json"), "w") as f:
        json.dump({**spheres, "lightz": []}, f)
    missing = {**spheres, "objects": [{"ply": "no_such_mesh.ply", "material": next(iter(spheres["materials"]))}]}
    missing.pop("generator", None)
    with open(os.path.join(TMP, "scene_missing_mesh.json"), "w") as f:
        json.dump(missing, f)
    cases += [
        ("plain_unknown", {"scenes": ["spheres", "scene_unknown.json"]}, "scenes[1]",
         'scene_unknown.json: unknown field "lightz"'),
        ("plain_base", {"scenes": [{"base": "scene_unknown.json"}]}, "scenes[0]", 'unknown field "lightz"'),
        ("plain_mesh", {"scenes": ["scene_missing_mesh.json"]}, "scenes[0]", "no_such_mesh.ply"),
    ]
    for name, fields, where, what in cases:
        p = check_only(write(name, [1] if fields is None else fields if isinstance(fields, str) else {**BASE, **fields}))
        line = p.stderr.strip()
        report(f"bad {name}: status 2, file, field and expectation",
               p.returncode == 2 and f"decl_{name}.json: {where}: " in line and what in line
               and "Traceback" not in p.stderr and len(line.splitlines()) == 1, line[-500:])

    # Every limit itself is allowed: the checks refuse what voxlab refuses, nothing it takes.
    edge = {**BASE, "seed": 2 ** 53, "truth_curve": {"spp": [1048576], "seed": 0, "size": [16384, 4096]},
            "runs": [{"res": [1, 1024], "size": [8192, 8192], "spp": [65536], "rays": [1048576]}],
            "scenes": ["spheres", {"base": "spheres", "name": "v", "vary": {"lights.0.irradiance": [[1, 1, 1]],
                                                                          "size": [[16384, 4096]]}}],
            "tolerances": {"mse": {"better": "lower"}, "render_ms": {"better": "lower"}}}
    p = check_only(write("edge", edge))
    report("a declaration at voxlab's limits passes --check", p.returncode == 0, p.stderr[-500:])

    # The run itself stops the same way before any job: no results folder, no cache.
    results = os.path.join(TMP, "results")
    p = check(write("run_variant", {**BASE, "scenes": [{"base": "spheres", "name": "v",
                                                        "set": {"lights.5.irradiance": [1, 1, 1]}}]}),
              "--results", results)
    report("a bad variant stops the run with status 2 before any job",
           p.returncode == 2 and "decl_run_variant.json: scenes[0].set.lights.5.irradiance: " in p.stderr
           and not os.path.exists(results), p.stderr[-500:])


if __name__ == "__main__":
    main()
    finish()
