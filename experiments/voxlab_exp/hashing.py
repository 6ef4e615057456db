"""Content hashes: of files (remembered per path, size and mtime) and of JSON-able objects.

Exists because cache keys, scene fingerprints and the voxlab snapshot all hash the same way; one
canonical JSON encoding keeps a key stable across runs and machines.
"""
import hashlib
import json
import os
import threading



def file_sha256(path, _memo={}, _lock=threading.Lock()):
    """sha256 of a file's contents, remembered per (path, size, mtime) for the life of the process."""
    st = os.stat(path)
    key = (os.path.abspath(path), st.st_size, st.st_mtime_ns)
    with _lock:
        if key in _memo:
            return _memo[key]
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    with _lock:
        _memo[key] = h.hexdigest()
    return _memo[key]


def canonical(obj):
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def sha256_of(obj):
    return hashlib.sha256(canonical(obj).encode()).hexdigest()
