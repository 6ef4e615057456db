"""Experiment declarations: read, checked against declaration.schema.json, defaults filled in, expanded.

Exists so that a declaration is checked completely before any job runs, and a bad field stops with
one message naming the file, the field (runs[0].res[1]), what was expected and what was found
(DeclarationError: exit status 2). The structure and every type and range are in the JSON Schema
(experiments/declaration.schema.json, checked with Debian's python3-jsonschema; its ranges are
voxlab's own); what a schema cannot say (no key given twice, scene files exist, scene names are
unique, a run's scene subset names declared scenes, the number of variants and configurations, image
sizes within voxlab's pixel cap, the truth curve's seed differs from the reference's) is checked here
after it. Two checks ask the voxlab binary, because only it knows the answer: every scene file and
every scene variant (applied to its scene) is read by voxlab's scene parser (`truth --dry-run`), and
every tolerance names one of its metrics (`compare --list-metrics`) or a baseline column.
"""
import concurrent.futures
import itertools
import json
import math
import os
import re

from .config import DEFAULT_VOXLAB, REPO, SEED
from .errors import DeclarationError, VoxlabError
from .hashing import canonical
from .scenes import SettingError, resolve_scene, scene_file_refusal, scene_refusal, variant_text

SCHEMA_PATH = os.path.join(REPO, "experiments", "declaration.schema.json")
RUN_DEFAULTS = {"models": "all", "size": "res", "spp": [4], "rays": [150], "cache": [True], "shadow_skip": [True],
                "shadows": ["march"]}
MAX_CONFIGS = 100000  # scene variants of one entry, or configurations of one run

_validator = None


def validator():
    """The Draft 7 validator for declaration.schema.json, with strict types: an integer is an int
    (not 1.0, not true) and a number is finite (Python's json reads NaN and Infinity)."""
    global _validator
    if _validator is None:
        from jsonschema import Draft7Validator, validators

        def is_int(_, v):
            return isinstance(v, int) and not isinstance(v, bool)

        def is_num(_, v):
            return is_int(_, v) or isinstance(v, float) and math.isfinite(v)

        checker = Draft7Validator.TYPE_CHECKER.redefine_many({"integer": is_int, "number": is_num})
        cls = validators.extend(Draft7Validator, type_checker=checker)
        with open(SCHEMA_PATH) as f:
            schema = json.load(f)
        cls.check_schema(schema)
        _validator = cls(schema)
    return _validator


def show(v):
    """A value as the message shows it: JSON, long strings cut."""
    try:
        return json.dumps(v) if not isinstance(v, str) or len(v) < 60 else json.dumps(v[:57] + "...")
    except (TypeError, ValueError):
        return repr(v)


def field_path(path):
    """jsonschema's path (deque of keys and indices) as runs[0].res[1]."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def _json_type(v):
    if isinstance(v, bool):
        return "boolean"
    if isinstance(v, int):
        return "integer"
    return {float: "number", str: "string", list: "array", dict: "object", type(None): "null"}.get(type(v), "?")


def _branch_types(schema):
    """The JSON types a branch of anyOf accepts (None: any)."""
    if "$ref" in schema:
        schema = validator().resolver.resolve(schema["$ref"])[1]
    t = schema.get("type")
    if t is not None:
        ts = set(t if isinstance(t, list) else [t])
        return ts | ({"integer"} if "number" in ts else set())
    if "enum" in schema or "const" in schema:
        return {_json_type(x) for x in schema.get("enum", [schema.get("const")])}
    return None


def _specific(e):
    """For an anyOf failure: the error of the one branch whose type the value has, when that branch
    says something more precise (a deeper field, a missing or unknown field, its own wording)."""
    while e.validator == "anyOf" and e.context:
        t = _json_type(e.instance)
        branches = [i for i, b in enumerate(e.validator_value) if (_branch_types(b) or {t}) & {t}]
        if len(branches) != 1:
            break
        sub = [c for c in e.context if c.relative_schema_path and c.relative_schema_path[0] == branches[0]]
        if not sub:
            break
        s = sub[0]
        if len(s.absolute_path) > len(e.absolute_path) or s.validator in ("required", "additionalProperties") \
                or "x-expected" in s.schema:
            e = s
        else:
            break
    return e


def explain(e):
    """(field, message) for a jsonschema ValidationError, in this project's words."""
    e = _specific(e)
    where = field_path(e.absolute_path)
    if e.validator == "additionalProperties" and isinstance(e.instance, dict):
        known = sorted(e.schema.get("properties", {}))
        extra = [k for k in e.instance if k not in e.schema.get("properties", {})]
        return (f"{where}.{extra[0]}" if where else extra[0]), f"unknown field (known: {', '.join(known)})"
    if e.validator == "required" and isinstance(e.instance, dict):
        missing = [k for k in e.validator_value if k not in e.instance]
        return where or "(top level)", f"missing required field \"{missing[0]}\""
    expected = e.schema.get("x-expected")
    if expected is None:  # a keyword the schema gives no wording for: jsonschema's own
        return where or "(top level)", e.message
    return where or "(top level)", f"expected {expected}, got {show(e.instance)}"


def check_schema(d, shown):
    """Raises DeclarationError for the first field of d that the schema rejects."""
    err = next(iter(validator().iter_errors(d)), None)
    if err is not None:
        where, msg = explain(err)
        raise DeclarationError(f"{shown}: {where}: {msg}")


def limit(name):
    """One of voxlab's limits as the schema states it: "seed" (its maximum) or "x-max-pixels"."""
    schema = validator().schema
    return schema["x-max-pixels"] if name == "x-max-pixels" else schema["definitions"][name]["maximum"]


def _strict_json(f, shown):
    """json.load that refuses a key given twice in one object: json keeps the last one silently, so a
    second "seed" further down would override the first without a word."""
    twice = {}  # id(object) -> (object, its first repeated key); the object is held so its id stays its own

    def pairs_hook(pairs):
        obj = dict(pairs)
        if len(obj) < len(pairs):
            seen = set()
            twice[id(obj)] = (obj, next(k for k, _ in pairs if k in seen or seen.add(k)))
        return obj

    d = json.load(f, object_pairs_hook=pairs_hook)
    where = _repeated_key_path(d, twice, [])
    if where:
        raise DeclarationError(f"{shown}: {field_path(where)}: given twice (JSON would keep only the last)")
    return d


def _repeated_key_path(v, twice, path):
    """The path (keys and indices) to the first repeated key that _strict_json recorded, in file order."""
    if isinstance(v, dict) and id(v) in twice:
        return path + [twice[id(v)][1]]
    for k, x in v.items() if isinstance(v, dict) else enumerate(v) if isinstance(v, list) else ():
        found = _repeated_key_path(x, twice, path + [k])
        if found:
            return found
    return None


def check_image_sizes(d, fail):
    """voxlab refuses an image of more than x-max-pixels (its MAX_IMAGE_PIXELS); the schema bounds each
    side only. N is an N x N image; "res" is at most 1024 x 1024 and "scene" is the scene's own size,
    which voxlab's scene parser checks."""
    cap = limit("x-max-pixels")
    sizes = [(f"runs[{i}].size", r.get("size")) for i, r in enumerate(d["runs"])]
    if "truth_curve" in d:
        sizes.append(("truth_curve.size", d["truth_curve"].get("size")))
    for where, v in sizes:
        w, h = (v, v) if isinstance(v, int) else v if isinstance(v, list) else (0, 0)
        if w * h > cap:
            fail(where, f"expected at most {cap} pixels (voxlab's limit), got {show(v)} ({w * h} pixels)")


def check_tolerance_names(tolerances, voxlab, fail):
    """A tolerance compares one column of the baseline: a metric of voxlab's (`compare --list-metrics`)
    or one of history.BASELINE_COLUMNS. Any other name would compare nothing ("n/a" in every row), so
    a misspelt gate would pass every run."""
    if not tolerances or voxlab is None:
        return
    from .history import BASELINE_COLUMNS  # not above: history imports rows, which imports this module
    from .jobs import metric_names
    known = list(dict.fromkeys(metric_names(voxlab) + BASELINE_COLUMNS))
    for name in tolerances:
        if name not in known:
            fail(f"tolerances.{name}", f"unknown metric (known: {', '.join(known)})")


def _declared_setting(field, variant):
    """The declared setting ("set.camera.fov_deg" or "vary.camera.fov_deg") behind a scene field as
    voxlab names it ("camera.fov_deg", "objects[0].params.count", or a field above or below a
    setting: "camera" for "camera.nope.x"); None when no setting touches it."""
    f = re.sub(r"\[(\d+)\]", r".\1", field)
    for k in sorted(variant["set"], key=lambda k: k != f):  # the exact one first
        if k == f or k.startswith(f + ".") or f.startswith(k + "."):
            return ("vary." if k in variant["vary"] else "set.") + k
    return None


def _dry_runs(refusal, items):
    """refusal(item) for each item, a few voxlab dry runs at a time (heightfield's generator takes
    0.3 s per scene)."""
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1)) as pool:
        return list(pool.map(refusal, items))


def check_plain_scenes(plain, voxlab, fail):
    """Has voxlab's scene parser read each plain scene file ((where, path) in declaration order), as
    check_variants does a variant: a scene file voxlab refuses (a field it does not know, a mesh that
    is missing) stops the declaration, not every one of its jobs."""
    if voxlab is None or not plain:
        return
    paths = list(dict.fromkeys(p for _, p in plain))
    refusals = dict(zip(paths, _dry_runs(lambda p: scene_file_refusal(voxlab, p), paths)))
    for where, path in plain:
        if refusals[path] is not None:
            shown = os.path.relpath(path, REPO) if path.startswith(REPO + os.sep) else path
            fail(where, f"scene file {shown}: {refusals[path]}")


def check_variants(variants, voxlab, fail):
    """Applies each variant ((where, variant) in declaration order) to its scene and, with a voxlab
    binary, has voxlab's scene parser read the result: a setting the scene has no place for or a value
    it refuses stops the declaration here, before any job, instead of failing every job of the variant."""
    texts = []
    for where, v in variants:
        try:
            texts.append(variant_text(v["base"], v["name"], v["set"]))
        except SettingError as e:
            fail(f"{where}.{_declared_setting(e.key, v)}", f"scene variant \"{v['name']}\": {e.key}: {e.why}")
        except VoxlabError as e:
            fail(f"{where}.base", e.args[0])
    if voxlab is None or not texts:
        return
    refusals = _dry_runs(lambda t: scene_refusal(voxlab, t), texts)
    for (where, v), why in zip(variants, refusals):
        if why is not None:
            setting = _declared_setting(why.split(":")[0], v)
            fail(f"{where}.{setting}" if setting else where, f"scene variant \"{v['name']}\": {why}")


def slug(v):
    s = json.dumps(v) if not isinstance(v, str) else v
    return re.sub(r"[^A-Za-z0-9.+=-]+", "-", s).strip("-") or "x"


def _size(v):
    """'res' (image N x N for voxel resolution N), 'scene' (the scene's own size), N -> [N, N], [W, H]."""
    return [v, v] if isinstance(v, int) else v


def _unique(v):
    return list(dict.fromkeys(v))  # in the order given


def load_declaration(path, voxlab=DEFAULT_VOXLAB):
    """Reads and checks an experiment declaration; returns it with defaults filled in and its scenes
    expanded (variants written into the cache later, by the scheduler). See experiments/README.md.
    voxlab: the binary whose scene parser and metrics the declaration is checked against; None skips
    those two checks (for a caller that runs nothing, such as a replot)."""
    path = os.path.abspath(path)
    shown = os.path.relpath(path, REPO) if path.startswith(REPO + os.sep) else path

    def fail(where, msg):
        raise DeclarationError(f"{shown}: {where}: {msg}")

    try:
        with open(path) as f:
            d = _strict_json(f, shown)
    except OSError as e:
        raise DeclarationError(f"{shown}: cannot read: {e.strerror}")
    except (ValueError, RecursionError) as e:
        raise DeclarationError(f"{shown}: not valid JSON: {e}")
    return declaration_from_dict(d, shown, os.path.dirname(path), path, voxlab)


def declaration_from_dict(d, shown="<declaration dict>", base_dir=None, path=None, voxlab=DEFAULT_VOXLAB):
    """The same checks and defaults for a declaration already parsed (the Python API's
    voxlab.experiment({...})): `shown` names it in messages, scene files resolve against base_dir
    (default: the current directory) and then scenes/; voxlab as for load_declaration."""
    base_dir = os.path.abspath(base_dir or os.getcwd())

    def fail(where, msg):
        raise DeclarationError(f"{shown}: {where}: {msg}")

    check_schema(d, shown)
    check_image_sizes(d, fail)
    decl = {
        "path": path,
        "shown": shown,
        "name": d["name"],
        "description": d.get("description", ""),
        "seed": d.get("seed", SEED),
        "truth_spp": d.get("truth_spp", 1024),
        "history": d.get("history", False),
        "timeout_s": d.get("timeout_s", 1800),
        "repeats": d.get("repeats", 5),  # timed truth and render runs
        "bake_repeats": d.get("bake_repeats", 1),
        "figure": d.get("figure", {}),
        "raw": d,
    }

    def scene_entry(v, where):
        if isinstance(v, str):
            try:
                p = resolve_scene(v, base_dir)
            except VoxlabError:
                fail(where, f"no scene file {v} (relative to the declaration) and no scenes/{v}.json")
            return [{"name": os.path.splitext(os.path.basename(p))[0], "path": p, "base": None, "set": {},
                     "vary": {}}]
        try:
            base = resolve_scene(v["base"], base_dir)
        except VoxlabError:
            fail(f"{where}.base", f"no scene file {v['base']} and no scenes/{v['base']}.json")
        name = v.get("name", os.path.splitext(os.path.basename(base))[0])
        if not re.match(r"^[A-Za-z0-9][A-Za-z0-9_.+=-]*$", name):  # a file name the schema could not see
            fail(f"{where}.name", f"expected a name (letters, digits, _ . + = -), got {show(name)}")
        sets, vary = v.get("set", {}), v.get("vary", {})
        keys = list(vary)
        # Counted before they are made: a few long lists multiply into more variants than any
        # experiment could run (and once hung the loader building them).
        combos = 1
        for k in keys:
            combos *= len(vary[k])
        if combos > MAX_CONFIGS:
            fail(f"{where}.vary", f"{combos} combinations of values (more than {MAX_CONFIGS})")
        if not sets and not vary:  # {"base": "bunny"} is the plain scene
            return [{"name": name, "path": base, "base": None, "set": {}, "vary": {}}]
        out = []
        for combo in itertools.product(*(vary[k] for k in keys)) if keys else [()]:
            settings = dict(sets)
            settings.update(zip(keys, combo))
            suffix = "".join(f"_{k.split('.')[-1]}{slug(val)}" for k, val in zip(keys, combo))
            out.append({"name": name + suffix, "path": None, "base": base, "base_name": name,
                        "set": settings, "vary": dict(zip(keys, combo))})
        return out

    entries = [(f"scenes[{i}]", scene_entry(v, f"scenes[{i}]")) for i, v in enumerate(d["scenes"])]
    scenes = [s for _, made in entries for s in made]
    seen = {}
    for s in scenes:
        if s["name"] in seen:
            fail("scenes", f"two scenes are named \"{s['name']}\" (give variants a \"name\")")
        seen[s["name"]] = s
    decl["scenes"] = scenes
    # A run may name a subset by scene name or by the name of a variant family (base_name).
    families = {}
    for s in scenes:
        families.setdefault(s["name"], []).append(s["name"])
        if s.get("base_name") and s["base_name"] != s["name"]:
            families.setdefault(s["base_name"], []).append(s["name"])

    def scene_subset(names, where):
        out = []
        for i, n in enumerate(names):
            if n not in families:
                fail(f"{where}[{i}]", f"\"{n}\" is not one of the declared scenes ({', '.join(families)})")
            out += families[n]
        return _unique(out)

    runs = []
    for i, r in enumerate(d["runs"]):
        r = {**RUN_DEFAULTS, **r}
        runs.append({
            "models": r["models"] if r["models"] == "all" else _unique(r["models"]),
            "res": _unique(r["res"]),
            "size": _size(r["size"]),
            "spp": _unique(r["spp"]),
            "rays": _unique(r["rays"]),
            "cache": _unique(r["cache"]),
            "shadow_skip": _unique(r["shadow_skip"]),
            "shadows": _unique(r["shadows"]),
            "scenes": scene_subset(r["scenes"], f"runs[{i}].scenes") if "scenes" in r else [s["name"] for s in scenes],
        })
    for i, r in enumerate(runs):
        n = len(r["scenes"]) * (len(r["models"]) if r["models"] != "all" else 1)
        for k in ("res", "spp", "rays", "cache", "shadow_skip", "shadows"):
            n *= len(r[k])
        if n > MAX_CONFIGS:
            fail(f"runs[{i}]", f"{n} configurations (scenes x models x res x spp x rays x cache x shadow_skip x "
                               f"shadows; "
                               f"more than {MAX_CONFIGS})")
    decl["runs"] = runs
    tc = d.get("truth_curve")
    if tc is not None:
        decl["truth_curve"] = {
            "spp": _unique(tc["spp"]),
            "seed": tc.get("seed", decl["seed"] + 1),
            "size": _size(tc.get("size", "scene")),
            "scenes": scene_subset(tc["scenes"], "truth_curve.scenes") if "scenes" in tc
            else [s["name"] for s in scenes],
        }
        if decl["truth_curve"]["seed"] == decl["seed"]:
            # Same seed, same sample pattern: the low-spp images would be correlated with the reference.
            fail("truth_curve.seed", "must differ from the experiment's seed (the reference's samples)")
        if decl["truth_curve"]["seed"] > limit("seed"):  # only the default, seed + 1, can be
            fail("truth_curve", f"its seed defaults to seed + 1 = {decl['truth_curve']['seed']}, above voxlab's "
                                f"limit 2^53: give truth_curve.seed")
    else:
        decl["truth_curve"] = None
    decl["tolerances"] = d.get("tolerances", {})
    # Last, as they run voxlab: a mistake the checks above can name is named without waiting for it.
    check_tolerance_names(decl["tolerances"], voxlab, fail)
    check_plain_scenes([(where, s["path"]) for where, made in entries for s in made if not s["base"]], voxlab, fail)
    check_variants([(where, s) for where, made in entries for s in made if s["base"]], voxlab, fail)
    return decl


def takes_shadow_method(model_info, method):
    """Whether a model, as `voxlab models` describes it ({"rule": its compositing}), can be rendered with
    shadow method `method`. A cone model (compositing "coverage": model.h's vx_compositing gives it to
    cone models only) has no voxels whose shadows the `voxel` method could precompute, and
    `voxlab render` refuses that pair (render_shadow_method_refused)."""
    return not (method == "voxel" and model_info.get("rule") == "coverage")


def expand_configs(decl, model_names, models_info=None):
    """Every configuration the declaration asks for, deduplicated, in declaration order. A model the
    binary does not know stays in the list (its rows record that it is not registered). With
    models_info (`voxlab models`' lines, jobs.models_info), "models": "all" leaves out the shadow
    methods a model cannot take (takes_shadow_method); a model named explicitly keeps them, and its
    rows record the binary's refusal."""
    out, seen = [], set()
    scenes = {s["name"]: s for s in decl["scenes"]}
    info = {m["name"]: m for m in models_info or []}
    for r in decl["runs"]:
        models = model_names if r["models"] == "all" else r["models"]
        for sc, res, m, spp, rays, cache, skip, sh in itertools.product(r["scenes"], r["res"], models, r["spp"],
                                                                         r["rays"], r["cache"], r["shadow_skip"],
                                                                         r["shadows"]):
            if r["models"] == "all" and m in info and not takes_shadow_method(info[m], sh):
                continue
            size = r["size"]
            cfg = {"scene": sc, "model": m, "res": res, "size": size, "spp": spp, "rays": rays, "cache": cache,
                   "shadow_skip": skip, "shadows": sh}
            k = canonical(cfg)
            if k not in seen:
                seen.add(k)
                cfg["scene_decl"] = scenes[sc]
                out.append(cfg)
    return out
