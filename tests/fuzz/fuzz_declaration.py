"""Mutation fuzzer for the experiment-declaration validator (experiments/voxlab_exp/schema.py's
load_declaration, which every `make table1/pareto/figures/regress` starts with).

Seeds are the shipped declarations (experiments/*.json). Each round mutates one seed, structurally
(a value replaced by one of another type or an extreme, a key deleted or added, a list emptied or
grown, objects nested) or as bytes (flips, truncation, splices), writes it beside the seeds'
folder layout and calls load_declaration. Allowed outcomes: a declaration, or DeclarationError /
VoxlabError with a message that names the file. Anything else (another exception, a call that runs
past --timeout seconds or a message without the file) is a finding: the input is saved in --crashes
as declaration-<sha1>.json and the run fails. Prints rounds, distinct outcomes (messages' first
words, the "coverage" of this loop) and findings.

    /usr/bin/python3 tests/fuzz/fuzz_declaration.py --seconds 60 [--seeds DIR] [--crashes DIR]
    /usr/bin/python3 tests/fuzz/fuzz_declaration.py --replay FILE   (re-runs one input)
"""
import argparse
import copy
import glob
import hashlib
import json
import os
import random
import re
import signal
import sys
import tempfile
import time
import traceback

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(REPO, "experiments"))
from voxlab_exp.errors import VoxlabError  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

KEYS = ["name", "description", "seed", "truth_spp", "scenes", "runs", "truth_curve", "history", "timeout_s",
        "tolerances", "figure", "comment", "models", "res", "size", "spp", "rays", "cache", "shadow_skip",
        "base", "set", "vary", "better", "rel", "abs", "gate", "camera.orbit.elevation_deg", "spheres", "bunny"]
EXTREMES = [None, True, False, 0, -1, 1, 2 ** 31, 2 ** 63, 2 ** 64 + 1, 1e308, -1e308, float("nan"), float("inf"),
            0.5, "", "all", "res", "scene", "16x16", "0x0", "99999999x99999999", "spheres", "../../etc/passwd",
            "/dev/zero", ".", "a" * 300, [], {}, [[]], [{}], {"base": "spheres"}, ["spheres"], [1, 2, 3],
            {"spp": [1]}, {"res": [8]}, {"better": "lower"}]


class Timeout(Exception):
    pass


def on_alarm(signum, frame):
    raise Timeout()


def random_value(rng, depth=0):
    r = rng.random()
    if r < 0.5 or depth > 3:
        return copy.deepcopy(rng.choice(EXTREMES))
    if r < 0.75:
        return [random_value(rng, depth + 1) for _ in range(rng.randrange(0, 4))]
    return {rng.choice(KEYS): random_value(rng, depth + 1) for _ in range(rng.randrange(0, 4))}


def containers(obj, out):
    """Every dict and list inside obj (obj included)."""
    if isinstance(obj, (dict, list)):
        out.append(obj)
        for v in (obj.values() if isinstance(obj, dict) else obj):
            containers(v, out)
    return out


def mutate_structure(rng, d):
    d = copy.deepcopy(d)
    for _ in range(rng.randrange(1, 4)):
        c = rng.choice(containers(d, []))
        op = rng.random()
        if isinstance(c, dict):
            if c and op < 0.35:
                c[rng.choice(list(c))] = random_value(rng)
            elif c and op < 0.5:
                del c[rng.choice(list(c))]
            elif op < 0.7:
                c[rng.choice(KEYS)] = random_value(rng)
            elif c:
                k = rng.choice(list(c))
                v = c[k]
                c[k] = [v, v] if not isinstance(v, list) else v * rng.randrange(0, 12)
        else:
            if c and op < 0.4:
                c[rng.randrange(len(c))] = random_value(rng)
            elif c and op < 0.6:
                del c[rng.randrange(len(c))]
            else:
                c.append(random_value(rng))
    return json.dumps(d, allow_nan=True).encode()


def mutate_bytes(rng, data):
    b = bytearray(data)
    for _ in range(rng.randrange(1, 8)):
        op = rng.random()
        if not b:
            b += b"{"
        i = rng.randrange(len(b))
        if op < 0.4:
            b[i] = rng.randrange(256)
        elif op < 0.6:
            del b[i:i + rng.randrange(1, 16)]
        elif op < 0.8:
            b[i:i] = rng.choice([b'"', b"{", b"}", b"[", b"]", b",", b":", b"1e999", b"NaN", b"\\u0000", b"\xff"])
        else:
            b = b[:i]
    return bytes(b)


def run_one(path, timeout):
    """None when the outcome is allowed, else a description of the finding; also an outcome key."""
    signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        load_declaration(path)
        return None, "ok"
    except Timeout:
        return f"load_declaration ran past {timeout} s", "timeout"
    except VoxlabError as e:
        msg = str(e)
        shown = os.path.basename(path)
        if shown not in msg:
            return f"message does not name the file: {msg}", "unnamed"
        key = re.sub(r"[0-9]+", "N", msg.split(": ", 2)[-1])[:40]
        return None, key
    except RecursionError:
        return "RecursionError (unbounded nesting)", "recursion"
    except Exception:
        return traceback.format_exc(limit=6), "exception"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60)
    ap.add_argument("--seeds", default=os.path.join(REPO, "experiments"))
    ap.add_argument("--crashes", default=os.path.join(REPO, "build", "fuzz", "crashes"))
    ap.add_argument("--timeout", type=float, default=5.0)
    ap.add_argument("--seed", type=int, default=int(time.time()))
    ap.add_argument("--replay")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="voxlab_fuzz_decl.")
    path = os.path.join(work, "declaration.json")
    if a.replay:
        with open(a.replay, "rb") as f, open(path, "wb") as g:
            g.write(f.read())
        finding, key = run_one(path, a.timeout)
        print(finding or f"no finding ({key})")
        return 1 if finding else 0
    seeds = []
    for p in sorted(glob.glob(os.path.join(a.seeds, "*.json"))):
        with open(p, "rb") as f:
            data = f.read()
        try:
            seeds.append((data, json.loads(data)))
        except ValueError:
            pass
    if not seeds:
        print(f"no seeds in {a.seeds}")
        return 1
    rng = random.Random(a.seed)
    os.makedirs(a.crashes, exist_ok=True)
    rounds, outcomes, findings = 0, set(), 0
    end = time.time() + a.seconds
    while time.time() < end:
        data, parsed = rng.choice(seeds)
        blob = mutate_structure(rng, parsed) if rng.random() < 0.7 else mutate_bytes(rng, data)
        with open(path, "wb") as f:
            f.write(blob)
        finding, key = run_one(path, a.timeout)
        rounds += 1
        outcomes.add(key)
        if finding:
            findings += 1
            out = os.path.join(a.crashes, "declaration-" + hashlib.sha1(blob).hexdigest() + ".json")
            with open(out, "wb") as f:
                f.write(blob)
            print(f"FINDING ({out}): {finding}")
            if findings >= 5:
                break
    print(f"seed {a.seed}: {rounds} rounds, {len(outcomes)} distinct outcomes, {findings} findings")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
