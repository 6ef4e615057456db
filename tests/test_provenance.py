"""EXR outputs carry their provenance as header attributes (voxlab:commit, voxlab:command, the scene's
name and hash, model, resolution, spp, seed), read here with OpenImageIO (an independent reader), and
`voxlab compare --json` echoes them; a PNG carries none and compare says nothing of it."""
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, finish, report, voxlab  # noqa: E402

SPHERES = os.path.join(REPO, "scenes", "spheres.json")


def header(path):
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    spec = inp.spec()
    out = {a.name: a.value for a in spec.extra_attribs if a.name.startswith("voxlab:")}
    inp.close()
    return out


truth = os.path.join(TMP, "truth.exr")
voxlab("truth", SPHERES, "--spp", 3, "--size", "24x16", "--seed", 5, "-o", truth)
render = os.path.join(TMP, "with space.exr")
voxlab("render", SPHERES, "--model", "heitz-neyret", "--res", 16, "--rays", 8, "--param", "edge_clear=0.25",
       "--size", "24x16", "--spp", 2, "-o", render)
version = voxlab("--version").stdout.split()[1]
scene_hash = None
h = header(truth)
report("truth EXR: commit, command, scene, spp, seed in its header",
       h.get("voxlab:commit") == version and h.get("voxlab:command", "").startswith("voxlab truth ")
       and h.get("voxlab:scene") == "spheres" and h.get("voxlab:spp") == "3" and h.get("voxlab:seed") == "5"
       and h.get("voxlab:size") == "24x16" and len(h.get("voxlab:scene_hash", "")) == 16, str(h))
r = header(render)
report("render EXR: model, resolution, rays, parameters, and the command quoted for a shell",
       r.get("voxlab:model") == "heitz-neyret" and r.get("voxlab:res") == "16" and r.get("voxlab:rays") == "8"
       and r.get("voxlab:model_params") == "edge_clear=0.25" and f"'{render}'" in r.get("voxlab:command", "")
       and r.get("voxlab:scene_hash") == h.get("voxlab:scene_hash"), str(r))
j = json.loads(voxlab("compare", truth, render, "--json").stdout)
p = j.get("provenance", {})
report("compare --json echoes both files' provenance",
       p.get("a", {}).get("command") == h.get("voxlab:command") and p.get("b", {}).get("model") == "heitz-neyret"
       and all(k in j for k in ("mse", "ssim", "width")), json.dumps(j)[:600])
png = os.path.join(TMP, "truth.png")
voxlab("truth", SPHERES, "--spp", 1, "--size", "24x16", "-o", png)
j = json.loads(voxlab("compare", png, png, "--json").stdout)
report("no provenance key for files without it (PNG)", "provenance" not in j, str(j))
finish()
