"""Scenes: finding a scene file, fingerprinting what its images depend on, writing variants.

Exists because cache keys must follow a scene's content (and the files it references), not its
path, and declarations make scene variants (fields replaced) that are written into the cache.
"""
import hashlib
import json
import os
import subprocess
import tempfile

from .config import REPO
from .errors import VoxlabError
from .files import write_text
from .hashing import file_sha256, sha256_of



def resolve_scene(arg, base_dir=None):
    """A scene name (scenes/<name>.json) or a path to a scene file (relative to base_dir, then cwd)."""
    for cand in ([os.path.join(base_dir, arg)] if base_dir and not os.path.isabs(arg) else []) + [arg]:
        if os.path.exists(cand) and os.path.isfile(cand):
            return os.path.abspath(cand)
    path = os.path.join(REPO, "scenes", arg + ".json")
    if os.path.exists(path):
        return path
    raise VoxlabError(f"--scene {arg}: no such file, and no scenes/{arg}.json")


def _scene_file_refs(scene):
    """Yields (container, key) for every file path a scene references (PLY/OBJ/glTF meshes, textures)."""
    objs = scene.get("objects") if isinstance(scene, dict) else None
    for o in objs if isinstance(objs, list) else []:
        if isinstance(o, dict):
            for k in ("ply", "obj", "gltf"):
                if isinstance(o.get(k), str):
                    yield o, k
    mats = scene.get("materials") if isinstance(scene, dict) else None
    for m in mats.values() if isinstance(mats, dict) else []:
        if isinstance(m, dict) and isinstance(m.get("texture"), str):
            yield m, "texture"


def _glb_json(path):
    """The JSON chunk of a binary glTF (.glb): its buffers and images may name files beside it."""
    with open(path, "rb") as f:
        head = f.read(20)
        if len(head) < 20 or head[:4] != b"glTF" or head[16:20] != b"JSON":
            raise ValueError("not a binary glTF")
        return json.loads(f.read(int.from_bytes(head[12:16], "little")))


def _referenced_fingerprint(path):
    """Content hash of a referenced file; for a glTF (.gltf or .glb) also of the buffers and images it
    names (a .glb's texture may lie beside it, as a .gltf's does)."""
    if not os.path.isfile(path):
        return "missing"
    h = file_sha256(path)
    if path.lower().endswith((".gltf", ".glb")):
        try:
            if path.lower().endswith(".glb"):
                g = _glb_json(path)
            else:
                with open(path) as f:
                    g = json.load(f)
            extra = []
            for item in (g.get("buffers") or []) + (g.get("images") or []):
                uri = item.get("uri") if isinstance(item, dict) else None
                if isinstance(uri, str) and not uri.startswith("data:"):
                    p = os.path.join(os.path.dirname(path), uri)
                    extra.append(file_sha256(p) if os.path.isfile(p) else "missing:" + uri)
            h = sha256_of([h, extra])
        except (OSError, ValueError, AttributeError):
            pass
    return h


# The fields of a scene that the voxel bake never reads: the grid covers the triangles' bounds and the
# bake sampler's rays start outside them (tracer/bake/bake.c), and voxlab's own scene identity, which a
# .vox file must match, also leaves them out. Variants that differ only here (another camera, another
# background) share one bake.
BAKE_IRRELEVANT = ("camera", "size", "background", "description", "name", "shadows")


def scene_fingerprint(path, for_bake=False):
    """sha256 of what a scene's images depend on: its JSON with each referenced file replaced by that
    file's content hash (so a variant with absolute paths hashes like its base, and an edited mesh
    changes the hash); for_bake drops the fields the bake ignores. An unparseable file hashes as its
    bytes (voxlab will report the problem when a job reads it)."""
    try:
        with open(path) as f:
            scene = json.load(f)
    except (OSError, ValueError):
        return file_sha256(path) if os.path.isfile(path) else "missing"
    if not isinstance(scene, dict):
        return file_sha256(path)
    base = os.path.dirname(os.path.abspath(path))
    for container, key in _scene_file_refs(scene):
        container[key] = "sha256:" + _referenced_fingerprint(os.path.join(base, container[key]))
    if for_bake:
        for k in BAKE_IRRELEVANT:
            scene.pop(k, None)
    return sha256_of(scene)


class SettingError(VoxlabError):
    """A variant's dotted path that does not fit its scene; `key` is the path as declared."""

    def __init__(self, variant, key, why):
        super().__init__(f"scene variant {variant}: {key}: {why}")
        self.key, self.why = key, why


def _set_dotted(obj, dotted, value, where):
    """Sets obj's field at a dotted path; a number indexes a list ("objects.0.params.count")."""
    keys = dotted.split(".")
    for i, k in enumerate(keys):
        last = i == len(keys) - 1
        if isinstance(obj, list):
            if not k.isdigit() or int(k) >= len(obj):
                raise SettingError(where, dotted, f"{k} is not an index of a list of {len(obj)}")
            k = int(k)
            if last:
                obj[k] = value
                return
            if not isinstance(obj[k], (dict, list)):
                obj[k] = {}
            obj = obj[k]
            continue
        if last:
            if value is None:
                obj.pop(k, None)
            else:
                obj[k] = value
            return
        if not isinstance(obj.get(k), (dict, list)):
            obj[k] = {}
        obj = obj[k]


def variant_text(base_path, name, settings):
    """base_path's scene with settings ({"camera.orbit.elevation_deg": 30, ...}; None deletes) applied,
    as the JSON text a variant file holds. Relative file references are made absolute (paths in a
    scene are relative to the scene file, and a variant lives elsewhere). Raises SettingError for a
    path the scene has no place for."""
    with open(base_path) as f:
        try:
            scene = json.load(f)
        except ValueError as e:
            raise VoxlabError(f"{base_path}: not valid JSON: {e}")
    if not isinstance(scene, dict):  # settings need fields to go into
        raise VoxlabError(f"{base_path}: not a scene (a JSON object)")
    base = os.path.dirname(os.path.abspath(base_path))
    for container, key in _scene_file_refs(scene):
        container[key] = os.path.normpath(os.path.join(base, container[key]))
    for dotted, value in settings.items():
        _set_dotted(scene, dotted, value, name)
    scene["name"] = name
    return json.dumps(scene, indent=1) + "\n"


def write_variant(base_path, name, settings, out_dir):
    """Writes the variant (variant_text) into out_dir (named by its content, so concurrent runs write
    the same file) and returns its path."""
    text = variant_text(base_path, name, settings)
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, f"{name}-{hashlib.sha256(text.encode()).hexdigest()[:12]}.json")
    if not os.path.exists(path):
        write_text(path, text)
    return path


def _dry_run_refusal(voxlab, path, tmp):
    """voxlab's words against the scene file at path (`truth --dry-run`, see scene_refusal), its own
    prefix and the file's name left out; None when it takes the scene."""
    cmd = [voxlab, "truth", path, "--dry-run", "--size", "1x1", "--spp", "1", "--threads", "1",
           "-o", os.path.join(tmp, "x.exr")]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        raise VoxlabError(f"cannot run {voxlab} to check the scenes ({e.strerror}): run make first")
    if p.returncode == 0:
        return None
    lines = p.stderr.strip().splitlines() or p.stdout.strip().splitlines() or [f"exit status {p.returncode}"]
    return lines[-1].removeprefix("voxlab truth: ").replace(path + ": ", "").replace(path + ".", "")


def scene_refusal(voxlab, text):
    """What voxlab's scene parser says against a scene (its JSON text), or None when it takes it.

    Asks `voxlab truth --dry-run` at 1x1 pixel and 1 spp, so that only the scene itself can be
    refused (not the estimate of a large image), and nothing is rendered or written. Every job kind
    reads its scene with the same parser, so a scene this takes is a scene no job refuses as such.
    Returns the message without voxlab's prefix and the temporary file's name: "camera.fov_deg:
    expected a finite number". Raises VoxlabError when voxlab cannot be run at all."""
    with tempfile.TemporaryDirectory(prefix="voxlab-variant-") as tmp:
        path = os.path.join(tmp, "scene.json")
        with open(path, "w") as f:
            f.write(text)
        msg = _dry_run_refusal(voxlab, path, tmp)
    return None if msg is None else msg.replace(path, "the variant")


def scene_file_refusal(voxlab, path):
    """scene_refusal for a scene file as it is (a declaration's plain scene): its meshes, textures
    and generators read from where the file names them."""
    with tempfile.TemporaryDirectory(prefix="voxlab-scene-") as tmp:
        return _dry_run_refusal(voxlab, path, tmp)
