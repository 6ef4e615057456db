"""voxlab in Python: the truth, bakes, renders and comparisons of the C core, in-process.

    import sys; sys.path.insert(0, "experiments")      # from the repository root
    import voxlab
    ref, _ = voxlab.truth("scenes/spheres.json", size=(64, 48), spp=64)
    img, stats = voxlab.render("scenes/spheres.json", model="alpha", res=32, size=(64, 48), spp=4, seed=1)
    print(voxlab.compare(ref, img))                      # {"mse": ..., "psnr": ..., "ssim": ..., ...}

Images are numpy float32 arrays of shape (height, width, 3), linear RGB, row 0 at the top: the
pixels `voxlab truth|render -o X.exr` writes, bit for bit. Statistics are the dicts `--stats`
writes. The calls go through build/libvoxlab.so (`make pylib`; tracer/api/voxlab_api.h) with
ctypes: no subprocess, no temporary file. A failure raises VoxlabError with voxlab's message.
Scenes are file paths or dicts (the scene file's JSON; relative paths in it resolve against
base_dir, default the current directory); Scene(...) loads one once for several calls.
experiment({...}) runs a declaration (experiments/README.md) through the experiment engine
(experiments/voxlab_exp/, which runs build/voxlab) and returns its rows as a pandas DataFrame.

$VOXLAB_LIB names another build of the library (default <repository>/build/libvoxlab.so).
"""
import ctypes
import json
import os

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LIB_PATH = os.environ.get("VOXLAB_LIB") or os.path.join(REPO, "build", "libvoxlab.so")

__all__ = ["VoxlabError", "Scene", "Bake", "truth", "bake", "render", "compare", "read_image", "models",
           "experiment"]


class VoxlabError(RuntimeError):
    """A voxlab call failed; the message is the one the command line prints after "voxlab CMD: "."""


_lib = None
_ERR_SIZE = 2048
_c_char_pp = ctypes.POINTER(ctypes.c_char_p)
_float_p = ctypes.POINTER(ctypes.c_float)


def _load():
    """Opens the library once and declares the signatures of tracer/api/voxlab_api.h."""
    global _lib
    if _lib is not None:
        return _lib
    if not os.path.exists(LIB_PATH):
        raise VoxlabError(f"{LIB_PATH}: no such library (build it with `make pylib`)")
    lib = ctypes.CDLL(LIB_PATH)
    P, I, LL, S, E = ctypes.c_void_p, ctypes.c_int, ctypes.c_longlong, ctypes.c_char_p, ctypes.c_size_t
    IP, FPP, SPP = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(_float_p), ctypes.POINTER(ctypes.c_void_p)
    sigs = {
        "vxapi_scene_load": (P, [S, S, S, S, E]),
        "vxapi_scene_free": (None, [P]),
        "vxapi_scene_size": (None, [P, IP, IP]),
        "vxapi_truth": (I, [P, I, I, I, LL, I, S, I, FPP, IP, IP, SPP, S, E]),
        "vxapi_bake_run": (P, [P, S, I, I, LL, I, _c_char_pp, I, SPP, S, E]),
        "vxapi_bake_load": (P, [P, S, S, S, E]),
        "vxapi_bake_save": (I, [P, S, S, E]),
        "vxapi_bake_free": (None, [P]),
        "vxapi_render": (I, [P, P, I, I, I, LL, I, I, I, S, S, I, FPP, IP, IP, SPP, S, E]),
        "vxapi_image_read": (I, [S, FPP, IP, IP, IP, S, E]),
        "vxapi_compare": (I, [_float_p, _float_p, I, I, I, SPP, S, E]),
        "vxapi_compare_files": (I, [S, S, SPP, S, E]),
        "vxapi_models": (I, [SPP]),
        "vxapi_free": (None, [P]),
    }
    for name, (res, args) in sigs.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = res, args
    _lib = lib
    return lib


def _enc(s):
    return None if s is None else os.fsencode(s)


class _Call:
    """The out-parameters every call shares: an error buffer, a pixel buffer and a stats text."""

    def __init__(self):
        self.err = ctypes.create_string_buffer(_ERR_SIZE)
        self.pixels = _float_p()
        self.w, self.h, self.c = ctypes.c_int(), ctypes.c_int(), ctypes.c_int(3)
        self.text = ctypes.c_void_p()

    def fail(self):
        self.release()
        raise VoxlabError(self.err.value.decode(errors="replace"))

    def image(self):
        """The returned pixels as a (height, width, channels) float32 array (a copy; the C buffer is freed)."""
        n = self.h.value * self.w.value * self.c.value
        a = np.ctypeslib.as_array(self.pixels, shape=(n,)).copy().reshape(self.h.value, self.w.value, self.c.value)
        _lib.vxapi_free(ctypes.cast(self.pixels, ctypes.c_void_p))
        self.pixels = _float_p()
        return a

    def json(self):
        if not self.text.value:
            return None
        s = ctypes.string_at(self.text.value).decode()
        _lib.vxapi_free(self.text)
        self.text = ctypes.c_void_p()
        return json.loads(s)

    def release(self):
        if self.pixels:
            _lib.vxapi_free(ctypes.cast(self.pixels, ctypes.c_void_p))
        if self.text.value:
            _lib.vxapi_free(self.text)


class Scene:
    """A scene loaded once: a file path, or a dict of the scene file's JSON (relative paths in it
    resolve against base_dir, default the current directory). Every function takes one of these
    or what it is made from."""

    def __init__(self, scene, base_dir=None):
        lib = _load()
        call = _Call()
        self._h = None
        if isinstance(scene, dict):
            text = json.dumps(scene).encode()
            self._h = lib.vxapi_scene_load(None, text, _enc(os.path.abspath(base_dir or os.getcwd())), call.err,
                                           _ERR_SIZE)
        elif isinstance(scene, (str, bytes, os.PathLike)):
            self._h = lib.vxapi_scene_load(_enc(scene), None, None, call.err, _ERR_SIZE)
        else:
            raise TypeError(f"a scene is a path or a dict, not {type(scene).__name__}")
        if not self._h:
            call.fail()
        w, h = ctypes.c_int(), ctypes.c_int()
        lib.vxapi_scene_size(self._h, ctypes.byref(w), ctypes.byref(h))
        self.size = (w.value, h.value)

    def __del__(self):
        if getattr(self, "_h", None) and _lib is not None:
            _lib.vxapi_scene_free(self._h)
            self._h = None


def _scene(scene, base_dir):
    return scene if isinstance(scene, Scene) else Scene(scene, base_dir)


def _size(size):
    if size is None:
        return 0, 0
    w, h = size
    if not (isinstance(w, (int, np.integer)) and isinstance(h, (int, np.integer))) or w < 1 or h < 1:
        raise ValueError(f"size must be (width, height), positive integers, not {size!r}")
    return int(w), int(h)


class Bake:
    """A bake in memory (from bake(), or a .vox file read by Bake.load); render(scene, vox=bake)
    renders it, save(path) writes it as the .vox file `voxlab bake` writes."""

    def __init__(self, handle, scene, stats):
        self._h, self.scene, self.stats = handle, scene, stats

    @classmethod
    def load(cls, scene, path, model=None, base_dir=None):
        """A .vox file for scene, checked as `render --vox` checks it (model: the one it must hold)."""
        s = _scene(scene, base_dir)
        call = _Call()
        h = _load().vxapi_bake_load(s._h, _enc(path), _enc(model), call.err, _ERR_SIZE)
        if not h:
            call.fail()
        return cls(h, s, None)

    def save(self, path):
        call = _Call()
        if _lib.vxapi_bake_save(self._h, _enc(path), call.err, _ERR_SIZE):
            call.fail()

    def __del__(self):
        if getattr(self, "_h", None) and _lib is not None:
            _lib.vxapi_bake_free(self._h)
            self._h = None


def truth(scene, size=None, spp=1024, seed=1, threads=0, base_dir=None, shadows=None, shadow_res=0):
    """`voxlab truth`: (image, stats); shadows "march" or "slicemap" (None: the scene's method)."""
    s = _scene(scene, base_dir)
    w, h = _size(size)
    call = _Call()
    if _lib.vxapi_truth(s._h, w, h, int(spp), int(seed), int(threads), _enc(shadows), int(shadow_res),
                        ctypes.byref(call.pixels),
                        ctypes.byref(call.w), ctypes.byref(call.h), ctypes.byref(call.text), call.err, _ERR_SIZE):
        call.fail()
    return call.image(), call.json()


def bake(scene, model, res, rays=150, seed=1, threads=0, params=None, out=None, base_dir=None):
    """`voxlab bake`: (Bake, stats); params a dict {name: value}; out: also write the .vox there."""
    s = _scene(scene, base_dir)
    assigns = [f"{k}={v!r}" if isinstance(v, float) else f"{k}={v}" for k, v in (params or {}).items()]
    arr = (ctypes.c_char_p * max(1, len(assigns)))(*[a.encode() for a in assigns])
    call = _Call()
    h = _lib.vxapi_bake_run(s._h, _enc(model), int(res), int(rays), int(seed), int(threads), arr, len(assigns),
                            ctypes.byref(call.text), call.err, _ERR_SIZE)
    if not h:
        call.fail()
    b = Bake(h, s, call.json())
    if out is not None:
        b.save(out)
    return b, b.stats


def render(scene, model=None, res=None, vox=None, size=None, spp=4, seed=1, rays=150, params=None, threads=0,
           cache=True, shadow_skip=True, backend="c", base_dir=None, shadows=None, shadow_res=0):
    """`voxlab render`: (image, stats). Bakes at res first (model, rays, params, seed: as
    `render --res`), or renders vox: a Bake or a .vox path (model then optional, checked)."""
    s = _scene(scene, base_dir)
    if (res is None) == (vox is None):
        raise ValueError("render needs exactly one of res (with model) and vox")
    if vox is None:
        if model is None:
            raise ValueError("render with res needs a model")
        b, _ = bake(s, model, res, rays=rays, seed=seed, threads=threads, params=params)
    elif isinstance(vox, Bake):
        b = vox
    else:
        if params:
            raise ValueError("params apply to a bake (res); a .vox file keeps its bake's parameters")
        b = Bake.load(s, vox, model)
    w, h = _size(size)
    call = _Call()
    if _lib.vxapi_render(s._h, b._h, w, h, int(spp), int(seed), int(threads), int(bool(cache)),
                         int(bool(shadow_skip)), _enc(backend), _enc(shadows), int(shadow_res),
                         ctypes.byref(call.pixels), ctypes.byref(call.w),
                         ctypes.byref(call.h), ctypes.byref(call.text), call.err, _ERR_SIZE):
        call.fail()
    return call.image(), call.json()


def read_image(path):
    """An image file as voxlab reads it (float values as stored): (height, width, channels) float32."""
    call = _Call()
    if _load().vxapi_image_read(_enc(path), ctypes.byref(call.pixels), ctypes.byref(call.w), ctypes.byref(call.h),
                                ctypes.byref(call.c), call.err, _ERR_SIZE):
        call.fail()
    return call.image()


def _as_image(x):
    a = read_image(x) if isinstance(x, (str, bytes, os.PathLike)) else np.asarray(x)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ValueError(f"an image is (height, width, channels) with 1 to 4 channels, not shape {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float32)


def compare(reference, image):
    """`voxlab compare A B --json`: {"mse", "psnr", "ssim", "width", "height"} (psnr None when identical).
    Arrays (height, width, channels) or image paths; two paths: their EXRs' "provenance" too."""
    paths = (str, bytes, os.PathLike)
    if isinstance(reference, paths) and isinstance(image, paths):
        call = _Call()
        if _load().vxapi_compare_files(_enc(reference), _enc(image), ctypes.byref(call.text), call.err, _ERR_SIZE):
            call.fail()
        return call.json()
    a, b = _as_image(reference), _as_image(image)
    if a.shape != b.shape:
        raise VoxlabError(f"image sizes differ: {a.shape[1]}x{a.shape[0]} with {a.shape[2]} channels vs "
                          f"{b.shape[1]}x{b.shape[0]} with {b.shape[2]} channels")
    call = _Call()
    # _load(): arrays may be the first thing a process hands the library (no Scene opened it yet).
    if _load().vxapi_compare(a.ctypes.data_as(_float_p), b.ctypes.data_as(_float_p), a.shape[1], a.shape[0],
                          a.shape[2], ctypes.byref(call.text), call.err, _ERR_SIZE):
        call.fail()
    return call.json()


def models():
    """The registered models' names (`voxlab models`)."""
    text = ctypes.c_void_p()
    if _load().vxapi_models(ctypes.byref(text)):
        raise VoxlabError("out of memory")
    names = ctypes.string_at(text.value).decode().split()
    _lib.vxapi_free(text)
    return names


def experiment(declaration, results=None, voxlab=None, jobs=2, fresh=False, out_dir=None, base_dir=None):
    """Runs a declared experiment (a dict as in experiments/*.json, or such a file's path) through the
    experiment engine, with its cache, as `experiments/sweep.py` does; returns the rows as a pandas
    DataFrame (df.attrs["meta"]: the run's machine, commit, settings). Its jobs run build/voxlab."""
    import sys

    import pandas as pd

    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # experiments/
    if here not in sys.path:
        sys.path.insert(0, here)
    import executors
    from voxlab_exp.config import DEFAULT_RESULTS, DEFAULT_VOXLAB
    from voxlab_exp.errors import VoxlabError as EngineError
    from voxlab_exp.rows import row_fields, run_experiment
    from voxlab_exp.schema import declaration_from_dict, load_declaration

    try:
        if isinstance(declaration, dict):
            decl = declaration_from_dict(declaration, base_dir=base_dir, voxlab=voxlab or DEFAULT_VOXLAB)
        else:
            decl = load_declaration(declaration, voxlab or DEFAULT_VOXLAB)
        meta, rows = run_experiment(decl, results=results or DEFAULT_RESULTS, voxlab=voxlab, jobs=jobs, fresh=fresh,
                                    out_dir=out_dir)
    except (EngineError, executors.ExecutorError) as e:
        raise VoxlabError(e.args[0]) from e
    df = pd.DataFrame(rows, columns=row_fields(meta["metrics"]))
    df.attrs["meta"] = meta
    return df
