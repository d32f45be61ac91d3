"""Execute the notebooks and store their outputs, small, so that a reader sees them on GitHub.

    python notebooks/execute.py                          # every notebooks/*.ipynb
    python notebooks/execute.py notebooks/01_quickstart.ipynb

Each notebook runs top to bottom in a fresh kernel (as the test suite runs it, with nbmake); its
pictures are scaled to at most MAX_WIDTH pixels and stored as COLORS-colour PNGs, or as JPEGs
where the PNG would pass LARGE bytes (fields of many colours), which keeps a figure in the tens of
kilobytes. The notebook's metadata records what its outputs
came from (`metadata.litl`): the date, the litl version and a fingerprint of its code cells that
ignores formatting (their syntax trees), so `tests/test_notebooks.py` fails when a code cell
changes and the stored outputs no longer show what it does. Run this again after editing one.
"""

from __future__ import annotations

import argparse
import ast
import base64
import datetime
import hashlib
import io
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
MAX_WIDTH = 800
COLORS = 128
LARGE = 48 * 1024
JPEG_QUALITY = 80
TIMEOUT_S = 1200


def fingerprint(notebook) -> str:
    """sha256 of the notebook's code cells as syntax trees (formatting and comments aside)."""
    digest = hashlib.sha256()
    for cell in notebook.cells:
        if cell.cell_type != "code":
            continue
        source = "".join(cell.source)
        try:
            text = ast.dump(ast.parse(source))
        except SyntaxError:  # (IPython magics) the text itself
            text = source
        digest.update(text.encode())
        digest.update(b"\0")
    return digest.hexdigest()


def shrink_png(data: str) -> tuple[str, str]:
    """A base64 PNG scaled to at most MAX_WIDTH pixels wide: (mime type, base64 data), a
    COLORS-colour PNG, or a JPEG where that PNG would pass LARGE bytes and the JPEG is smaller."""
    from PIL import Image

    image = Image.open(io.BytesIO(base64.b64decode(data)))
    image.load()
    if image.width > MAX_WIDTH:
        height = round(image.height * MAX_WIDTH / image.width)
        image = image.convert("RGBA").resize((MAX_WIDTH, height), Image.LANCZOS)
    image = image.convert("RGB")
    png = io.BytesIO()
    image.quantize(colors=COLORS, method=Image.Quantize.MEDIANCUT).save(png, format="PNG", optimize=True)
    best = ("image/png", png.getvalue())
    if len(best[1]) > LARGE:
        jpeg = io.BytesIO()
        image.save(jpeg, format="JPEG", quality=JPEG_QUALITY, optimize=True)
        if len(jpeg.getvalue()) < len(best[1]):
            best = ("image/jpeg", jpeg.getvalue())
    return best[0], base64.b64encode(best[1]).decode()


def execute(path: pathlib.Path) -> int:
    """Run one notebook, shrink its pictures, stamp it and write it back; returns its size."""
    import nbformat
    from nbclient import NotebookClient

    import litl

    notebook = nbformat.read(path, as_version=4)
    NotebookClient(
        notebook, timeout=TIMEOUT_S, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}
    ).execute()
    for cell in notebook.cells:
        if cell.cell_type != "code":
            continue
        for output in cell.get("outputs", []):
            if output.get("output_type") == "error":
                raise RuntimeError(
                    f"{path.name}: a cell failed: {output.get('ename')}: {output.get('evalue')}"
                )
            data = output.get("data", {})
            if "image/png" in data:
                mime, encoded = shrink_png(data.pop("image/png"))
                data[mime] = encoded
    notebook.metadata["litl"] = {
        "executed": datetime.date.today().isoformat(),
        "litl_version": litl.__version__,
        "code_fingerprint": fingerprint(notebook),
    }
    nbformat.write(notebook, path)
    return path.stat().st_size


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python notebooks/execute.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("notebooks", nargs="*", type=pathlib.Path, help="default: notebooks/*.ipynb")
    args = parser.parse_args(argv)
    paths = args.notebooks or sorted(HERE.glob("*.ipynb"))
    for path in paths:
        if path.suffix != ".ipynb" or not path.is_file():
            parser.error(f"not a notebook: {path}")
    for path in paths:
        print(f"{path.name}: {execute(path) / 1024:.0f} KiB", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
