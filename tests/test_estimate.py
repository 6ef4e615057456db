"""`--dry-run` and the up-front memory check (tracer/cli/estimate.c): a dry run computes and writes
nothing, and says what the run would need; a run whose estimate exceeds the memory available
($VOXLAB_MEMORY_BUDGET here, the machine's MemAvailable and ulimit -v otherwise) is refused at once
with the estimate, exit status 1, no output. The estimates are checked against independent
references: the image's own size, and the grid voxlab really builds (its --stats voxel count)."""
import json
import os
import re
import time

from testlib import REPO, TMP, finish, report, voxlab

SPHERES = os.path.join(REPO, "scenes", "spheres.json")


def path(name):
    return os.path.join(TMP, name)


def field(text, label):
    m = re.search(label + r"\s+([0-9.]+)", text)
    return float(m.group(1)) if m else None


# ---------- dry runs write nothing ----------
for cmd, args, out in [
    ("truth", ["--size", "640x480", "--spp", "64"], "t.exr"),
    ("bake", ["--model", "alpha", "--res", "48"], "b.vox"),
    ("render", ["--model", "vmesh", "--res", "48", "--size", "64x64"], "r.png"),
]:
    p = voxlab(cmd, SPHERES, *args, "--dry-run", "-o", path(out), "--stats", path(out + ".json"), check=False)
    report(f"{cmd} --dry-run: exit 0, says it is a dry run", p.returncode == 0 and "dry run" in p.stdout, p.stdout + p.stderr)
    report(f"{cmd} --dry-run: writes nothing", not os.path.exists(path(out)) and not os.path.exists(path(out + ".json")))
    report(f"{cmd} --dry-run: prints memory, rays and time", all(w in p.stdout for w in ("memory (estimate)", "rays", "time (estimate)")),
           p.stdout)
    if cmd == "truth":
        # Independent reference: the float RGBA image alone is 640*480*16 bytes; the rays are the pixels
        # times spp times (1 + the spheres' one shadowing light).
        gib = field(p.stdout, r"image")
        report("truth estimate holds at least the image itself", gib is not None and gib * 2 ** 30 >= 640 * 480 * 16 * 0.999,
               p.stdout)
        report("truth estimate counts camera and shadow rays", field(p.stdout, "rays") == 640 * 480 * 64 * 2, p.stdout)

# ---------- the voxel estimate against the grid voxlab builds ----------
for res in (32, 96):
    p = voxlab("bake", SPHERES, "--model", "alpha", "--res", res, "--dry-run", "-o", path("x.vox"))
    est = field(p.stdout, r"voxels \(estimate\)")
    voxlab("bake", SPHERES, "--model", "alpha", "--res", res, "--rays", 1, "-o", path("x.vox"), "--stats", path("x.json"))
    real = json.load(open(path("x.json")))["voxels"]
    report(f"voxel estimate within a factor of 3 of the real grid ({res}^3)",
           est is not None and real / 3 <= est <= real * 3, f"estimate {est}, real {real}")

# ---------- render --vox --dry-run estimates from the file's header (its voxels and records) ----------
# (x.vox is the 96^3 alpha bake above: `real` voxels of 40 bytes)
p = voxlab("render", SPHERES, "--vox", path("x.vox"), "--dry-run", "-o", path("y.exr"))
est_vox = field(p.stdout, r"voxels \(estimate\)")
report("render --vox --dry-run counts the file's voxels (its header's exact count, not an estimate)",
       p.returncode == 0 and est_vox == real, f"render estimate {est_vox}, the grid's {real}")
# The grid is rebuilt from the file's cells, without the n^3 bit array a bake's voxelisation needs:
# the header alone is read by a dry run, so a copy claiming 1024^3 shows it (128 MiB of bits).
with open(path("x.vox"), "rb") as f:
    raw = bytearray(f.read())
raw[8 + 48:8 + 52] = (1024).to_bytes(4, "little")  # the header's n
with open(path("x1024.vox"), "wb") as f:
    f.write(raw)
p = voxlab("render", SPHERES, "--vox", path("x1024.vox"), "--dry-run", "-o", path("y.exr"))
gib_records, gib_grid = field(p.stdout, "records"), field(p.stdout, "grid")
report("render --vox --dry-run: the file's records, and a grid without the 1024^3 bit array",
       gib_records is not None and abs(gib_records * 2 ** 30 - real * 40) <= 0.001 * 2 ** 30
       and gib_grid is not None and gib_grid * 2 ** 30 < 1024 ** 3 / 8 / 4, p.stdout)
p = voxlab("render", SPHERES, "--model", "alpha", "--res", "1024", "--dry-run", "-o", path("y.exr"))
report("render --res 1024 --dry-run still counts the bake's bit array",
       field(p.stdout, "grid") is not None and field(p.stdout, "grid") * 2 ** 30 >= 1024 ** 3 / 8, p.stdout)
with open(path("x.vox"), "rb") as f:
    raw = bytearray(f.read())
raw[8 + 48:8 + 52] = (100000).to_bytes(4, "little")  # the header's n
with open(path("bad_n.vox"), "wb") as f:
    f.write(raw)
p = voxlab("render", SPHERES, "--vox", path("bad_n.vox"), "--dry-run", "-o", path("y.exr"), check=False)
report("render --vox --dry-run with a bad resolution names the file and the field",
       p.returncode == 1 and "bad_n.vox: header field n" in p.stderr, p.stderr)

# ---------- refusal ----------
env_budget = {"VOXLAB_MEMORY_BUDGET": str(64 * 2 ** 20)}  # 64 MiB
import subprocess  # noqa: E402  (voxlab() has no env argument)
from testlib import VOXLAB  # noqa: E402

for cmd, args, out in [
    ("truth", ["--size", "4096x4096", "--spp", "1"], "big.exr"),  # 256 MiB of float RGBA
    ("render", ["--model", "alpha", "--res", "1024", "--size", "64x64"], "big.png"),  # 128 MiB of dense bits
    ("bake", ["--model", "heitz-neyret", "--res", "1024"], "big.vox"),
]:
    t0 = time.time()
    p = subprocess.run([VOXLAB, cmd, SPHERES, *args, "-o", path(out)], capture_output=True, text=True,
                       env={**os.environ, **env_budget})
    took = time.time() - t0
    report(f"{cmd}: a run over the memory budget is refused with status 1", p.returncode == 1, p.stderr)
    report(f"{cmd}: the refusal gives the estimate and the budget",
           re.match(rf"^voxlab {cmd}: needs about [0-9.]+ GiB of memory \(scene .*\), more than the 0\.06 GiB available", p.stderr)
           is not None, p.stderr)
    report(f"{cmd}: refused up front (no work, no output)", took < 30 and not os.path.exists(path(out)), f"{took:.1f} s")
    p = subprocess.run([VOXLAB, cmd, SPHERES, *args, "--dry-run", "-o", path(out)], capture_output=True, text=True,
                       env={**os.environ, **env_budget})
    report(f"{cmd} --dry-run over the budget: status 1, says refused", p.returncode == 1 and "refused:" in p.stdout,
           p.stdout)
finish()
