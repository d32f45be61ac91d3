"""The README's Python examples run as written (`python -m litl` itself: tests/test_cli.py)."""

import pathlib
import re

import jax.numpy as jnp


README = pathlib.Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_examples_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks, "README has no python examples"
    namespace = {}
    exec(compile("\n".join(blocks), str(README), "exec"), namespace)
    assert namespace["trajectory"].snapshots.shape == (20, 64, 64, 2)  # the closed-loop example
    assert namespace["features"].shape == (2 * 6 * 2,)
    assert all(bool(jnp.isfinite(v)) for v in namespace["losses"].values())
    tmp = pathlib.Path(namespace["tmp"])                            # the robots examples
    for picture in ("biped.png", "biped.gif", "my_rhino.png"):
        assert (tmp / picture).stat().st_size > 1000
    assert namespace["positions"].shape == (10, namespace["robot"].layout.n_particles, 2)
    assert namespace["mine"].n_actuators == 2 and "head" in namespace["mine"].layout.groups
    assert namespace["rhino"].n_actuators == 8
    assert len(namespace["result"].metrics) == 2 * 2 * 2                # the loop example
    assert namespace["final"]["design"].shape == (2, 4)
