"""Images: EXR reading and sRGB previews (from jobexec, shared with the workers), labelled strips.

Exists so that tables, figures, the demo and the dashboard draw images the same way.
"""
import jobexec

from .files import save_png

read_exr = jobexec.read_exr
srgb8 = jobexec.srgb8
exr_to_png = jobexec.exr_to_png


def label_font(size):
    from PIL import ImageFont

    try:  # matplotlib ships DejaVu Sans, so this works wherever the script's dependencies are installed
        from matplotlib import font_manager

        return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)
    except Exception:
        return ImageFont.load_default()


def make_strip(tiles, size, path):
    """tiles: [(title, subtitle, PIL image size x size)]; one column each, labels in a band above.
    Each label shrinks until it fits its column and is clipped to it, so narrow strips (32 px
    columns) stay legible instead of running labels into each other."""
    from PIL import Image, ImageDraw

    font_px = max(8, min(13, size // 6))
    band = 2 * font_px + 6
    strip = Image.new("RGB", (size * len(tiles), band + size), (255, 255, 255))
    fonts = {}
    for i, (title, subtitle, img) in enumerate(tiles):
        label = Image.new("RGB", (size, band), (255, 255, 255))
        draw = ImageDraw.Draw(label)
        for row, (text, colour) in enumerate([(title, (0, 0, 0)), (subtitle, (70, 70, 70))]):
            px = font_px
            while True:
                font = fonts.setdefault(px, label_font(px))
                if px <= 6 or draw.textlength(text, font=font) <= size - 3:
                    break
                px -= 1
            draw.text((2, 2 + row * (font_px + 2)), text, fill=colour, font=font)
        if i:
            draw.line([(0, 0), (0, band - 1)], fill=(190, 190, 190))  # separators only in the label band
        strip.paste(label, (i * size, 0))
        strip.paste(img.convert("RGB").resize((size, size)), (i * size, band))
    save_png(strip, path)


def error_map(ref_exr, img_exr):
    """An error heat map (PIL RGB image): mean absolute error over the colour channels, black at zero
    and pale yellow at the image's own largest error (matplotlib's inferno, as `voxlab compare
    --heatmap` draws it). Each map has its own scale: compare the MSE column, not the colours."""
    import numpy as np
    from matplotlib import colormaps
    from PIL import Image

    a, b = read_exr(ref_exr)[..., :3], read_exr(img_exr)[..., :3]
    err = np.abs(a.astype(np.float64) - b).mean(axis=2)
    top = err.max()
    rgb = colormaps["inferno"](err / top if top > 0 else err)[..., :3]
    return Image.fromarray((rgb * 255 + 0.5).astype(np.uint8), "RGB")
