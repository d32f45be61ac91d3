"""The notebooks are stored with their outputs, small, and the outputs are those of the code shown
(notebooks/execute.py writes them; nbmake executes the notebooks themselves in the test suite)."""

import base64
import importlib.util
import io
import json
import pathlib

import numpy as np
import pytest
from PIL import Image

ROOT = pathlib.Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
IMAGES = ("image/png", "image/jpeg")


def _execute_module():
    spec = importlib.util.spec_from_file_location("notebook_execute", ROOT / "notebooks" / "execute.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_there_are_notebooks():
    assert len(NOTEBOOKS) >= 3


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_a_notebook_shows_its_outputs_and_they_are_its_codes(path):
    import nbformat

    notebook = nbformat.read(path, as_version=4)
    stamp = notebook.metadata.get("litl")
    assert stamp, f"{path.name} is stored without outputs: run python notebooks/execute.py {path.name}"
    assert stamp["code_fingerprint"] == _execute_module().fingerprint(notebook), (
        f"{path.name}'s code changed since its outputs were stored: run python notebooks/execute.py"
    )
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert all(cell.outputs for cell in code), f"{path.name}: a code cell has no stored output"
    outputs = [output for cell in code for output in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"], f"{path.name} stored an error"
    assert any(mime in o.get("data", {}) for o in outputs for mime in IMAGES), f"{path.name}: no picture"


def test_the_stored_notebooks_stay_small():
    sizes = {path.name: path.stat().st_size for path in NOTEBOOKS}
    assert max(sizes.values()) < 400_000, sizes
    assert sum(sizes.values()) < 600_000, sizes


def _png(array: np.ndarray) -> str:
    buffer = io.BytesIO()
    Image.fromarray(array).save(buffer, format="PNG")
    return base64.b64encode(buffer.getvalue()).decode()


def test_pictures_are_scaled_down_and_noisy_ones_stored_as_jpeg():
    execute = _execute_module()
    flat = np.zeros((400, 1600, 3), np.uint8)
    flat[:, 800:] = (200, 30, 30)
    mime, data = execute.shrink_png(_png(flat))
    image = Image.open(io.BytesIO(base64.b64decode(data)))
    assert mime == "image/png" and image.size == (execute.MAX_WIDTH, 200)
    noisy = np.random.default_rng(0).integers(0, 256, (600, 800, 3), dtype=np.uint8)
    mime, data = execute.shrink_png(_png(noisy))
    assert mime == "image/jpeg" and len(base64.b64decode(data)) < len(base64.b64decode(_png(noisy)))


def test_the_fingerprint_ignores_formatting_but_not_code():
    import nbformat

    execute = _execute_module()

    def notebook(source):
        return nbformat.v4.new_notebook(
            cells=[nbformat.v4.new_markdown_cell("# a"), nbformat.v4.new_code_cell(source)]
        )

    same = execute.fingerprint(notebook("x = f(1, 'a')"))
    assert execute.fingerprint(notebook('x = f(\n    1, "a"\n)  # why')) == same
    assert execute.fingerprint(notebook("x = f(2, 'a')")) != same


def test_the_script_refuses_what_is_not_a_notebook(capsys):
    with pytest.raises(SystemExit) as exit_:
        _execute_module().main([str(ROOT / "README.md")])
    assert exit_.value.code == 2 and "not a notebook" in capsys.readouterr().err


def test_no_stored_output_names_this_machine():
    for path in NOTEBOOKS:
        text = json.dumps(json.loads(path.read_text())["cells"])
        assert str(ROOT) not in text, path.name
