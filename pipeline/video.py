"""From linear EXR frames to pictures: exposure, a filmic curve, sRGB, PNG, a contact
sheet, and H.264 through ffmpeg."""

import os
import shutil
import struct
import subprocess
import textwrap
import zlib

import numpy as np

from volpath.tonemap import MIDDLE, display, log_brightness  # noqa: F401  (display: the pipeline's curve)


def tonemap(image, exposure=0.0):
    """Linear radiance -> 8-bit sRGB (``display``, rounded)."""
    return np.round(display(image, exposure) * 255).astype(np.uint8)


def auto_exposure(images, frames, window=12):
    """Stops per frame that bring a robust brightness of each frame to the display's middle
    (volpath.tonemap.auto_exposure), averaged in log over the frames within +-``window`` so
    the picture brightens smoothly as the sun rises."""
    logs, frames = np.array([log_brightness(img) for img in images]), np.asarray(frames)
    smooth = np.array([logs[np.abs(frames - f) <= window].mean() for f in frames])
    return np.clip(np.log2(MIDDLE) - smooth, -10.0, 12.0)


def write_png(path, rgb):
    """An 8-bit RGB PNG (no dependency beyond zlib), written atomically."""
    rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
    height, width, _ = rgb.shape
    raw = np.concatenate([np.zeros((height, 1), np.uint8), rgb.reshape(height, -1)], axis=1).tobytes()

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw, 6))
        + chunk(b"IEND", b"")
    )
    tmp = f"{path}.tmp"
    with open(tmp, "wb") as f:
        f.write(png)
    os.replace(tmp, path)


# A 3x5-pixel font for the contact sheet's labels: rows top to bottom, bits left to right.
_GLYPHS = {
    "0": (7, 5, 5, 5, 7),
    "1": (2, 6, 2, 2, 7),
    "2": (7, 1, 7, 4, 7),
    "3": (7, 1, 7, 1, 7),
    "4": (5, 5, 7, 1, 1),
    "5": (7, 4, 7, 1, 7),
    "6": (7, 4, 7, 5, 7),
    "7": (7, 1, 1, 1, 1),
    "8": (7, 5, 7, 5, 7),
    "9": (7, 5, 7, 1, 7),
    ".": (0, 0, 0, 0, 2),
    "s": (0, 3, 6, 3, 6),
    " ": (0, 0, 0, 0, 0),
    # Capitals and punctuation, for the contact sheet's caption.
    "A": (2, 5, 7, 5, 5),
    "B": (6, 5, 6, 5, 6),
    "C": (3, 4, 4, 4, 3),
    "D": (6, 5, 5, 5, 6),
    "E": (7, 4, 6, 4, 7),
    "F": (7, 4, 6, 4, 4),
    "G": (3, 4, 5, 5, 3),
    "H": (5, 5, 7, 5, 5),
    "I": (7, 2, 2, 2, 7),
    "J": (1, 1, 1, 5, 2),
    "K": (5, 5, 6, 5, 5),
    "L": (4, 4, 4, 4, 7),
    "M": (5, 7, 7, 5, 5),
    "N": (6, 5, 5, 5, 5),
    "O": (2, 5, 5, 5, 2),
    "P": (6, 5, 6, 4, 4),
    "Q": (2, 5, 5, 6, 3),
    "R": (6, 5, 6, 5, 5),
    "S": (3, 4, 2, 1, 6),
    "T": (7, 2, 2, 2, 2),
    "U": (5, 5, 5, 5, 7),
    "V": (5, 5, 5, 5, 2),
    "W": (5, 5, 7, 7, 5),
    "X": (5, 5, 2, 5, 5),
    "Y": (5, 5, 2, 2, 2),
    "Z": (7, 1, 2, 4, 7),
    "'": (2, 2, 0, 0, 0),
    "(": (1, 2, 2, 2, 1),
    ")": (4, 2, 2, 2, 4),
    ",": (0, 0, 0, 2, 4),
    "-": (0, 0, 7, 0, 0),
    ":": (0, 2, 0, 2, 0),
    ";": (0, 2, 0, 2, 4),
    "_": (0, 0, 0, 0, 7),
    "/": (1, 1, 2, 4, 4),
}


def _bitmap(text, scale):
    """``text`` as a 0/1 bitmap, a blank pixel around it (characters without a glyph are blanks)."""
    # Four columns a character: its three, then a blank one.
    glyphs = [_GLYPHS.get(c, _GLYPHS[" "]) for c in text]
    rows = np.array([[(g[r] << 1 >> (3 - b)) & 1 for g in glyphs for b in range(4)] for r in range(5)], np.uint8)
    return np.kron(np.pad(rows, 1), np.ones((scale, scale), np.uint8))


def label(picture, text, scale=1):
    """``text`` (digits, '.', 's', spaces) in white on black at the picture's bottom left."""
    glyphs = _bitmap(text, scale)
    h, w = min(glyphs.shape[0], picture.shape[0]), min(glyphs.shape[1], picture.shape[1])
    picture[-h:, :w] = glyphs[-h:, :w, None] * 255
    return picture


def caption_band(width, text, scale=1):
    """A black band ``width`` pixels wide with ``text`` in white capitals, wrapped at spaces."""
    lines = textwrap.wrap(text.upper(), max(1, (width // scale - 2) // 4)) or [""]
    line_height = 7 * scale
    band = np.zeros((len(lines) * line_height, width, 3), np.uint8)
    for i, line in enumerate(lines):
        glyphs = _bitmap(line, scale)[:, :width]
        band[i * line_height : i * line_height + glyphs.shape[0], : glyphs.shape[1]] = glyphs[..., None] * 255
    return band


def contact_sheet(images, columns=6, labels=None, caption=None):
    """Tone-mapped frames side by side, in rows of ``columns``, each with its label if given;
    ``caption``, a line of words under them (what the animation animates)."""
    if not images:
        raise ValueError("no frames for a contact sheet")
    h, w, _ = images[0].shape
    rows = (len(images) + columns - 1) // columns
    cols = min(columns, len(images))
    sheet = np.zeros((rows * h, cols * w, 3), np.uint8)
    for i, img in enumerate(images):
        r, c = divmod(i, columns)
        tile = img.copy()
        if labels is not None:
            label(tile, labels[i], scale=max(1, h // 90))
        sheet[r * h : (r + 1) * h, c * w : (c + 1) * w] = tile
    if caption:
        sheet = np.concatenate([sheet, caption_band(sheet.shape[1], caption, scale=max(1, h // 90))])
    return sheet


def ffmpeg():
    """Debian's ffmpeg if installed, else the binary in the imageio-ffmpeg wheel."""
    found = shutil.which("ffmpeg")
    if found:
        return found
    try:
        import imageio_ffmpeg
    except ImportError:
        raise RuntimeError("no ffmpeg: install Debian's ffmpeg or `pip install imageio-ffmpeg`") from None
    return imageio_ffmpeg.get_ffmpeg_exe()


def encode(png_pattern, output, fps=24, crf=18):
    """PNGs named by a printf pattern numbered from 0 -> H.264 yuv420p MP4 (atomic)."""
    tmp = output + ".tmp.mp4"
    cmd = [
        ffmpeg(),
        "-y",
        "-loglevel",
        "error",
        "-framerate",
        str(fps),
        "-i",
        png_pattern,
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuv420p",
        "-crf",
        str(crf),
        # yuv420p needs even sizes
        "-vf",
        "pad=ceil(iw/2)*2:ceil(ih/2)*2",
        "-movflags",
        "+faststart",
        tmp,
    ]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise RuntimeError(f"ffmpeg failed ({r.returncode}): {r.stderr.strip()[-2000:]}")
    os.replace(tmp, output)
    return output


def count_frames(path):
    """Frames in a video, counted by decoding it with ffmpeg (as ffprobe -count_frames)."""
    r = subprocess.run(
        [ffmpeg(), "-nostdin", "-i", path, "-map", "0:v:0", "-f", "null", "-"], capture_output=True, text=True
    )
    if r.returncode != 0:
        raise RuntimeError(f"ffmpeg could not read {path}: {r.stderr.strip()[-500:]}")
    counts = [line for line in r.stderr.replace("\r", "\n").splitlines() if line.startswith("frame=")]
    return int(counts[-1].split("=")[1].split()[0])
