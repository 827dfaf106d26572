"""docs/python.md's tutorial runs and draws its picture.

Usage: tutorial_test.py REPO_ROOT MODULE_DIR CLI_DIR (MODULE_DIR: <build>/python; CLI_DIR: the
directory of the `geoprox` binary). Exits 77 with one line when the module was not built.

The ```python blocks of docs/python.md are joined and run as one script, in a temporary
directory holding data/meshes/spot.obj, twice: with matplotlib as installed, and with it hidden
(a package `matplotlib` on PYTHONPATH that raises ImportError), where the tutorial draws through
`geoprox render`. Each run must succeed and leave spot-field.png, a PNG that is not blank: many
distinct colours, and no colour on more than 95% of it.
"""

from __future__ import annotations

import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

if len(sys.argv) != 4:
    sys.exit("usage: tutorial_test.py REPO_ROOT MODULE_DIR CLI_DIR")
ROOT, MODULE_DIR, CLI_DIR = (Path(a).resolve() for a in sys.argv[1:4])
if not list((MODULE_DIR / "geoprox").glob("native*.so")):
    print(f"SKIP: geoprox.native was not built in {MODULE_DIR} (sanitizer build, or no "
          "pybind11/numpy)")
    sys.exit(77)


def tutorial_code() -> str:
    text = (ROOT / "docs" / "python.md").read_text()
    blocks = re.findall(r"^```python\n(.*?)^```$", text, flags=re.S | re.M)
    if len(blocks) < 4:
        raise AssertionError(f"docs/python.md has {len(blocks)} python blocks, expected 4+")
    return "\n".join(blocks)


def png_pixels(path: Path) -> list[tuple[int, ...]]:
    """The pixels of an 8-bit RGB or RGBA, non-interlaced PNG (what matplotlib and geoprox
    render write), decoded here so that the check needs nothing installed."""
    data = path.read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise AssertionError(f"{path} is not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"IDAT":
            idat += chunk
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in (2, 6) or interlace:
        raise AssertionError(f"unexpected PNG format {header}")
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, previous = [], bytearray(stride)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b = previous[x]
            c = previous[x - bpp] if x >= bpp else 0
            if kind == 1:
                line[x] = (line[x] + a) & 255
            elif kind == 2:
                line[x] = (line[x] + b) & 255
            elif kind == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        previous = line
    return [tuple(row[i:i + 3]) for row in rows for i in range(0, stride, bpp)]


def run(label: str, hide_matplotlib: bool) -> None:
    tmp = Path(tempfile.mkdtemp(prefix="geoprox-tutorial-"))
    try:
        (tmp / "data" / "meshes").mkdir(parents=True)
        shutil.copy(ROOT / "data" / "meshes" / "spot.obj", tmp / "data" / "meshes")
        (tmp / "tutorial.py").write_text(tutorial_code())
        path = [str(MODULE_DIR)]
        if hide_matplotlib:
            (tmp / "hide" / "matplotlib").mkdir(parents=True)
            (tmp / "hide" / "matplotlib" / "__init__.py").write_text(
                "raise ImportError('matplotlib hidden by tutorial_test.py')\n")
            path.insert(0, str(tmp / "hide"))
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(path),
                   PATH=str(CLI_DIR) + os.pathsep + os.environ.get("PATH", ""),
                   MPLCONFIGDIR=str(tmp / "mpl"))
        done = subprocess.run([sys.executable, "tutorial.py"], cwd=tmp, env=env,
                              capture_output=True, text=True, timeout=500)
        if done.returncode != 0:
            raise AssertionError(f"{label}: the tutorial failed:\n{done.stdout}\n{done.stderr}")
        if "wrote spot-field.png" not in done.stdout:
            raise AssertionError(f"{label}: no 'wrote spot-field.png' in\n{done.stdout}")
        if hide_matplotlib and "render: wrote spot-field.png" not in done.stderr:
            raise AssertionError(f"{label}: geoprox render did not draw:\n{done.stderr}")
        pixels = png_pixels(tmp / "spot-field.png")
        counts: dict[tuple[int, ...], int] = {}
        for p in pixels:
            counts[p] = counts.get(p, 0) + 1
        commonest = max(counts.values()) / len(pixels)
        if len(counts) < 100 or commonest > 0.95:
            raise AssertionError(f"{label}: spot-field.png looks blank ({len(counts)} colours, "
                                 f"the commonest on {commonest:.0%} of the pixels)")
        print(f"{label}: ran, spot-field.png has {len(pixels)} pixels, {len(counts)} colours, "
              f"background {commonest:.0%}")
        print(done.stdout, end="")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


try:
    import matplotlib  # noqa: F401
    has_matplotlib = True
except ImportError:
    has_matplotlib = False
if has_matplotlib:
    run("with matplotlib", hide_matplotlib=False)
else:
    print("matplotlib is not installed (python3-matplotlib): only the geoprox render branch runs")
run("with geoprox render", hide_matplotlib=True)
