"""`voxlab compare` against numpy and scikit-image on seeded image pairs.

Images go to the C tool as PFM (float32, read losslessly by OpenImageIO; PFM stores the bottom row
first, which OIIO flips back). The reference is computed on the same float32 values widened to
float64, because skimage computes in the input's precision and voxlab computes in double: that makes
the comparison exact up to rounding order instead of float32 noise.
"""
import os
import sys

import numpy as np
from scipy import ndimage
from skimage.metrics import structural_similarity

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import TMP, finish, report, voxlab  # noqa: E402

TOL = 1e-6


def write_pfm(path, img):
    img = np.asarray(img, dtype=np.float32)
    h, w = img.shape[:2]
    grey = img.ndim == 2
    with open(path, "wb") as f:
        f.write(b"Pf\n" if grey else b"PF\n")
        f.write(f"{w} {h}\n-1.0\n".encode())  # negative scale = little-endian
        f.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())


def reference(a, b):
    a64, b64 = a.astype(np.float64), b.astype(np.float64)
    mse = float(np.mean((a64 - b64) ** 2))
    ssim = float(structural_similarity(a64, b64, gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
                                       data_range=1, channel_axis=-1 if a.ndim == 3 else None))
    return mse, ssim


def gradient(rng, h, w, channels):
    y, x = np.mgrid[0:h, 0:w]
    base = [(x / w) * 0.8 + 0.1, (y / h) * 0.7 + 0.2, 0.5 + 0.3 * np.sin(x / 5.0) * np.cos(y / 7.0)]
    img = np.stack(base[:channels], axis=-1) + rng.normal(0, 0.05, (h, w, channels))
    img = np.clip(img, 0, 1)
    return (img[..., 0] if channels == 1 else img).astype(np.float32)


def cases():
    rng = np.random.default_rng(20240611)
    g = gradient(rng, 48, 64, 1)
    yield "grey 64x48 blurred", g, ndimage.gaussian_filter(g, 1.2).astype(np.float32)
    c = gradient(rng, 48, 64, 3)
    yield "rgb 64x48 noisy", c, np.clip(c + rng.normal(0, 0.03, c.shape), 0, 1).astype(np.float32)
    c2 = gradient(rng, 53, 37, 3)
    yield "rgb 37x53 shifted", c2, np.roll(c2, (2, -3), axis=(0, 1))
    yield "rgb 37x53 blurred", c2, ndimage.gaussian_filter(c2, (2.0, 2.0, 0)).astype(np.float32)
    yield "grey 11x11 random", rng.random((11, 11), dtype=np.float32), rng.random((11, 11), dtype=np.float32)
    yield "rgb 11x17 random", rng.random((17, 11, 3), dtype=np.float32), rng.random((17, 11, 3), dtype=np.float32)
    yield "grey 20x30 constants", np.full((30, 20), 0.2, np.float32), np.full((30, 20), 0.7, np.float32)
    yield "grey 20x30 constant vs noise", np.full((30, 20), 0.5, np.float32), rng.random((30, 20), dtype=np.float32)
    out = (rng.random((31, 40, 3)) * 1.2 - 0.1).astype(np.float32)  # a few values outside [0, 1]
    yield "rgb 40x31 out of range", out, (out * 0.9 + 0.05).astype(np.float32)
    yield "rgb 64x48 identical", c, c.copy()


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(26)
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big"), head[24], head[25]


def write_exr(path, img, names):
    """An EXR whose channels carry the given names (OpenImageIO marks "A" as the alpha channel)."""
    import OpenImageIO as oiio
    h, w, n = img.shape
    spec = oiio.ImageSpec(w, h, n, "float")
    spec.channelnames = tuple(names)
    spec.alpha_channel = names.index("A") if "A" in names else -1
    out = oiio.ImageOutput.create(path)
    ok = out.open(path, spec) and out.write_image(np.ascontiguousarray(img, np.float32)) and out.close()
    assert ok, path


def read_pfm(path):
    with open(path, "rb") as f:
        grey = f.readline().strip() == b"Pf"
        w, h = map(int, f.readline().split())
        f.readline()
        img = np.frombuffer(f.read(), "<f4").reshape(h, w, *(() if grey else (3,)))[::-1]
    return img.astype(np.float32)


def channels_named(pair):
    """A second or fourth channel is alpha only when the file names it so: (R, G) is refused with its
    names, (R, G, B, Z) is colour (Z left out), (R, G, B, A) colour with alpha ignored."""
    a, b = read_pfm(pair[0]), read_pfm(pair[1])
    mse, _ = reference(a, b)
    depth = np.full(a.shape[:2] + (1,), 7.0, np.float32)
    rgbz_a, rgbz_b = os.path.join(TMP, "rgbz_a.exr"), os.path.join(TMP, "rgbz_b.exr")
    write_exr(rgbz_a, np.concatenate([a, depth], -1), ["R", "G", "B", "Z"])
    write_exr(rgbz_b, np.concatenate([b, depth + 1], -1), ["R", "G", "B", "Z"])
    p = voxlab("compare", rgbz_a, rgbz_b, "--json", check=False)
    got = __import__("json").loads(p.stdout) if p.returncode == 0 else {}
    report("R, G, B, Z: the colour compared, Z left out (not read as alpha)",
           p.returncode == 0 and abs(got.get("mse", -1) - mse) <= TOL, f"{p.stderr.strip()} {got} want mse {mse}")
    p = voxlab("compare", rgbz_a, pair[1], "--json", check=False)
    report("R, G, B, Z against R, G, B: 3 channels each", p.returncode == 0, p.stderr.strip())
    rg = os.path.join(TMP, "rg.exr")
    write_exr(rg, a[..., :2], ["R", "G"])
    p = voxlab("compare", rg, rg, "--json", check=False)
    report("R, G: refused, naming the file and its channels (not read as grey + alpha)",
           p.returncode == 1 and p.stdout == "" and rg in p.stderr and "(R, G)" in p.stderr
           and "grey + alpha" in p.stderr, p.stderr.strip())
    ya_a, ya_b = os.path.join(TMP, "ya_a.exr"), os.path.join(TMP, "ya_b.exr")
    write_exr(ya_a, np.stack([a[..., 0], a[..., 1]], -1), ["Y", "A"])
    write_exr(ya_b, np.stack([b[..., 0], a[..., 2]], -1), ["Y", "A"])
    p = voxlab("compare", ya_a, ya_b, "--json", check=False)
    got = __import__("json").loads(p.stdout) if p.returncode == 0 else {}
    want, _ = reference(a[..., 0], b[..., 0])
    report("Y, A: grey + alpha, alpha ignored", p.returncode == 0 and abs(got.get("mse", -1) - want) <= TOL,
           f"{p.stderr.strip()} {got} want {want}")


def non_finite(pair):
    """An image with NaN or infinite colour values is refused, naming it, the count and the first
    pixel (its metrics were null, which the tables showed as a missing row); alpha may hold anything."""
    a = read_pfm(pair[0])
    bad = a.copy()
    bad[5, 7, 1] = np.nan
    bad[9, 2, 0] = np.inf
    pb = os.path.join(TMP, "nonfinite.pfm")
    write_pfm(pb, bad)
    heat = os.path.join(TMP, "nonfinite_heat.png")
    p = voxlab("compare", pair[0], pb, "--json", "--heatmap", heat, check=False)
    report("NaN / inf colour values: refused, naming the image, the count and the first pixel",
           p.returncode == 1 and p.stdout == "" and pb in p.stderr and "second image has 2 NaN or infinite" in p.stderr
           and "x=7, y=5" in p.stderr and not os.path.exists(heat), p.stderr.strip())
    p = voxlab("compare", pb, pair[0], check=False)
    report("... as the first image too", p.returncode == 1 and "first image has 2" in p.stderr, p.stderr.strip())
    rgba = os.path.join(TMP, "nan_alpha.exr")
    write_exr(rgba, np.concatenate([a, np.full(a.shape[:2] + (1,), np.nan, np.float32)], -1), ["R", "G", "B", "A"])
    p = voxlab("compare", rgba, rgba, "--json", check=False)
    report("NaN in alpha only: compared (alpha is not colour)", p.returncode == 0, p.stderr.strip())


def main():
    worst = 0.0
    paths = {}
    for name, a, b in cases():
        tag = name.replace(" ", "_")
        pa, pb = os.path.join(TMP, tag + "_a.pfm"), os.path.join(TMP, tag + "_b.pfm")
        write_pfm(pa, a)
        write_pfm(pb, b)
        paths[name] = (pa, pb)
        p = voxlab("compare", pa, pb, "--json", check=False)
        if p.returncode != 0:
            report(f"compare runs ({name})", False, p.stderr.strip())
            continue
        got = __import__("json").loads(p.stdout)
        mse, ssim = reference(a, b)
        report(f"mse matches numpy ({name})", abs(got["mse"] - mse) <= TOL, f"got {got['mse']!r}, want {mse!r}")
        d = abs(got["ssim"] - ssim)
        worst = max(worst, d)
        report(f"ssim matches skimage ({name})", d <= TOL, f"got {got['ssim']!r}, want {ssim!r}")
        if mse == 0:
            report(f"psnr null when identical ({name})", got["psnr"] is None, f"got {got['psnr']!r}")
        else:
            want = 10 * np.log10(1 / mse)
            report(f"psnr ({name})", got["psnr"] is not None and abs(got["psnr"] - want) <= 1e-6 * max(1, want),
                   f"got {got['psnr']!r}, want {want!r}")
        h, w = a.shape[:2]
        report(f"size in json ({name})", got["width"] == w and got["height"] == h, p.stdout.strip())
    print(f"# max |ssim - skimage| = {worst:.3g}")

    pa, pb = paths["rgb 64x48 noisy"]
    heat = os.path.join(TMP, "heat.png")
    p = voxlab("compare", pa, pb, "--heatmap", heat, check=False)
    report("heatmap run", p.returncode == 0, p.stderr.strip())
    report("heatmap is a 64x48 RGB 8-bit PNG", os.path.exists(heat) and png_size(heat) == (64, 48, 8, 2),
           f"IHDR {png_size(heat) if os.path.exists(heat) else 'missing'}")
    report("human output", all(k in p.stdout for k in ("MSE", "PSNR", "SSIM")), p.stdout.strip())

    other = paths["rgb 37x53 shifted"][0]
    p = voxlab("compare", pa, other, "--json", check=False)
    report("size mismatch fails", p.returncode != 0 and p.stdout == "", f"rc {p.returncode}, stdout {p.stdout!r}")
    report("size mismatch names both files", pa in p.stderr and other in p.stderr and "64x48" in p.stderr
           and "37x53" in p.stderr and p.stderr.startswith("voxlab compare: "), p.stderr.strip())

    grey = paths["grey 64x48 blurred"][0]
    p = voxlab("compare", pa, grey, check=False)
    report("channel mismatch fails", p.returncode != 0 and pa in p.stderr and grey in p.stderr, p.stderr.strip())

    channels_named(paths["rgb 64x48 noisy"])
    non_finite(paths["rgb 64x48 noisy"])

    small = os.path.join(TMP, "small.pfm")
    write_pfm(small, np.zeros((8, 8), np.float32))
    p = voxlab("compare", small, small, "--json", check=False)
    report("smaller than 11x11 fails", p.returncode != 0 and "11x11" in p.stderr and small in p.stderr,
           p.stderr.strip())

    missing = os.path.join(TMP, "does_not_exist.exr")
    p = voxlab("compare", pa, missing, check=False)
    report("missing file fails", p.returncode == 1 and missing in p.stderr
           and p.stderr.startswith("voxlab compare: "), p.stderr.strip())

    p = voxlab("compare", pa, pb, "--bogus", check=False)
    report("unknown option fails", p.returncode == 1 and "--bogus" in p.stderr, p.stderr.strip())
    p = voxlab("compare", pa, check=False)
    report("one image fails", p.returncode == 1 and "usage" in p.stderr, p.stderr.strip())
    p = voxlab("compare", pa, pb, "--heatmap", check=False)
    report("--heatmap without file fails", p.returncode == 1, p.stderr.strip())
    bad_heat = os.path.join(TMP, "no_dir", "heat.png")
    p = voxlab("compare", pa, pb, "--heatmap", bad_heat, check=False)
    report("heatmap into missing dir fails", p.returncode == 1 and bad_heat in p.stderr, p.stderr.strip())
    finish()


main()
