"""The README's Python examples run as written, and `python -m litl` runs end to end."""

import json
import pathlib
import re

import jax.numpy as jnp

import litl.__main__ as cli

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


def test_main_runs_a_tiny_optimization(tmp_path, capsys):
    assert cli.main(["--iterations", "2", "--steps", "40", "--out", str(tmp_path)]) == 0
    lines = (tmp_path / "metrics.jsonl").read_text().splitlines()
    records = [json.loads(line) for line in lines]
    assert [r["iteration"] for r in records] == [0, 1]
    assert all(isinstance(r["task_loss"], float) for r in records)
    assert "iteration 1" in capsys.readouterr().out


def test_main_rejects_bad_arguments(capsys):
    import pytest
    with pytest.raises(SystemExit):
        cli.main(["--iterations", "0"])
    assert "must be positive" in capsys.readouterr().err
