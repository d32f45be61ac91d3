"""The determinism switch (`LITL_DETERMINISM`), its XLA flag, and what a run directory records."""

import json
import os
import pathlib
import subprocess
import sys
import warnings

import pytest

import litl
from litl import backend
from litl.backend import DeterminismError, configure, requested_mode
from litl.loop.run import RunDirectoryError, run
from litl.records import provenance
from tests.loop.tiny import tiny_config, tiny_robot
from tests.processes import child_environment

# Physics, gradients and determinism: worth running on a GPU (`pytest -m gpu`).
pytestmark = pytest.mark.gpu

ROOT = pathlib.Path(__file__).resolve().parents[1]
FLAG = "--xla_gpu_deterministic_ops"


@pytest.mark.parametrize(
    ("environ", "expected"),
    [
        ({}, ("on", "default")),
        ({"LITL_DETERMINISM": "on"}, ("on", "LITL_DETERMINISM")),
        ({"LITL_DETERMINISM": " OFF "}, ("off", "LITL_DETERMINISM")),
        ({"XLA_FLAGS": f"--xla_cpu_x=1 {FLAG}=false"}, ("off", "XLA_FLAGS")),
        ({"XLA_FLAGS": f"{FLAG}=true"}, ("on", "XLA_FLAGS")),
        ({"XLA_FLAGS": f"{FLAG}=false {FLAG}=true"}, ("on", "XLA_FLAGS")),  # XLA keeps the last
        ({"LITL_DETERMINISM": "off", "XLA_FLAGS": f"{FLAG}=false"}, ("off", "LITL_DETERMINISM")),
    ],
)
def test_the_mode_comes_from_the_switch_or_the_users_xla_flag(environ, expected):
    assert requested_mode(environ) == expected


def test_an_unknown_mode_is_an_error_naming_the_allowed_values():
    with pytest.raises(DeterminismError, match=r"'maybe'.*LITL_DETERMINISM=on.*LITL_DETERMINISM=off"):
        requested_mode({"LITL_DETERMINISM": "maybe"})
    with pytest.raises(DeterminismError, match="expects true or false"):
        requested_mode({"XLA_FLAGS": f"{FLAG}=perhaps"})


@pytest.mark.parametrize(("switch", "flag"), [("on", "false"), ("off", "true")])
def test_a_contradiction_with_the_users_xla_flags_is_reported_not_resolved(switch, flag):
    environ = {"LITL_DETERMINISM": switch, "XLA_FLAGS": f"{FLAG}={flag}"}
    with pytest.raises(DeterminismError, match="contradicts XLA_FLAGS"):
        configure(environ)
    assert environ["XLA_FLAGS"] == f"{FLAG}={flag}"  # untouched


def test_configure_adds_the_flag_to_the_users_flags_and_never_removes_one():
    environ = {"XLA_FLAGS": "--xla_backend_optimization_level=0 --xla_dump_to=/tmp/x"}
    assert configure(environ) == "on"
    assert environ["XLA_FLAGS"] == f"--xla_backend_optimization_level=0 --xla_dump_to=/tmp/x {FLAG}=true"
    configure(environ)  # a second import (a subprocess inheriting the environment) adds nothing
    assert environ["XLA_FLAGS"].count(FLAG) == 1
    environ = {"LITL_DETERMINISM": "off", "XLA_FLAGS": "--xla_dump_to=/tmp/x"}
    assert configure(environ) == "off"
    assert environ["XLA_FLAGS"] == "--xla_dump_to=/tmp/x"
    environ = {}
    configure(environ)
    assert environ["XLA_FLAGS"] == f"{FLAG}=true"


def test_a_child_process_decides_its_own_mode_over_the_flag_its_parent_litl_added():
    parent = {"XLA_FLAGS": "--xla_dump_to=/tmp/x"}
    configure(parent)
    child = {**parent, "LITL_DETERMINISM": "off"}
    assert configure(child) == "off"
    assert child["XLA_FLAGS"] == "--xla_dump_to=/tmp/x" and "LITL_XLA_FLAG_ADDED" not in child
    back_on = {**child, "LITL_DETERMINISM": "on"}
    assert configure(back_on) == "on"
    assert back_on["XLA_FLAGS"] == f"--xla_dump_to=/tmp/x {FLAG}=true"
    # The user's own flag is their word: the same flag without litl's note still contradicts.
    with pytest.raises(DeterminismError, match="contradicts"):
        configure({"XLA_FLAGS": f"{FLAG}=true", "LITL_DETERMINISM": "off"})


def test_import_litl_asks_for_determinism_before_jax_starts():
    # This process imported litl (conftest's flags kept): XLA saw the flag when JAX started.
    assert f"{FLAG}=true" in os.environ["XLA_FLAGS"]
    assert "--xla_backend_optimization_level=0" in os.environ["XLA_FLAGS"]
    assert litl.backend.mode() == "on"


def test_a_bad_switch_stops_the_command_line_with_one_line_and_writes_nothing(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "litl", "+scale=smoke"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env=child_environment(LITL_DETERMINISM="yes please"),
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "litl: error: LITL_DETERMINISM='yes please' is not a mode litl knows: use LITL_DETERMINISM=on "
        "(deterministic GPU computations, the default) or LITL_DETERMINISM=off (XLA's faster, "
        "run-to-run varying ones)."
    ]
    assert list(tmp_path.iterdir()) == []


def test_the_run_directory_records_the_mode_and_a_resume_in_another_mode_says_so(
    tmp_path, monkeypatch, capfd
):
    config = tiny_config(loop={"episodes": 2}, seeds=1, observer={"kind": "kmeans"})
    run(tiny_robot(), config, tmp_path, progress=False, stop_after_episodes=1)
    recorded = json.loads((tmp_path / "run.json").read_text())["backend"]
    assert recorded["determinism"] == "on"
    assert recorded["platform"] == backend.record()["platform"]
    assert FLAG in recorded["xla_flags"]

    # run.json names the litl that made the run (litl.records.provenance); as if another commit had
    # started it, the resume below also says so and records it.
    saved = json.loads((tmp_path / "run.json").read_text())
    assert saved["provenance"] == json.loads(json.dumps(provenance.record()))
    saved["provenance"]["commit"] = "0" * 40
    (tmp_path / "run.json").write_text(json.dumps(saved))

    capfd.readouterr()
    monkeypatch.setattr(backend, "_configured", "off")  # as a process started with LITL_DETERMINISM=off
    run(tiny_robot(), config, tmp_path, progress=False)
    err = capfd.readouterr().err
    assert "was started with determinism on and is resumed with determinism off" in err
    assert "LITL_DETERMINISM=on to resume" in err
    assert "was started by litl 0.1.0, commit 000000000000" in err
    assert "its iterations come from two versions of litl" in err
    settings = json.loads((tmp_path / "run.json").read_text())
    assert settings["backend"]["determinism"] == "on"  # what it started with stays
    assert settings["provenance"]["commit"] == "0" * 40
    assert [r["determinism"] for r in settings["resumed_on"]] == ["off"]
    assert [r["provenance"] for r in settings["resumed_on"]] == [json.loads(json.dumps(provenance.record()))]
    # A resume refused for other settings changes nothing, run.json included.
    before = (tmp_path / "run.json").read_text()
    with pytest.raises(RunDirectoryError, match="Nothing was changed"):
        run(tiny_robot(), config.replace(seeds=2), tmp_path, progress=False)
    assert (tmp_path / "run.json").read_text() == before


class _FakeDevice:
    device_kind = "NVIDIA H100 80GB HBM3"
    platform = "gpu"


@pytest.mark.parametrize(
    ("version", "warns"), [("0.10.2", True), ("0.11.0", True), ("0.11.1", False), ("0.10.1", False)]
)
def test_a_cuda_jaxlib_with_the_slow_scatter_warns_once_naming_the_fix(monkeypatch, version, warns):
    import jax
    import jaxlib

    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    monkeypatch.setattr(jax, "devices", lambda: [_FakeDevice()])
    monkeypatch.setattr(jaxlib, "__version__", version)
    monkeypatch.setattr(backend, "_warned_slow_scatter", False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        backend.warn_if_slow_gpu_scatter()
        backend.warn_if_slow_gpu_scatter()
    messages = [str(w.message) for w in caught]
    if warns:
        assert len(messages) == 1
        assert f"jaxlib {version}" in messages[0] and 'pip install -U "jax[cuda12]>=0.11.1"' in messages[0]
    else:
        assert messages == []


def test_a_deterministic_run_on_a_gpu_says_what_it_costs_and_how_to_lift_it(monkeypatch):
    import jax

    monkeypatch.setattr(jax, "default_backend", lambda: "cpu")
    monkeypatch.setattr(backend, "_configured", "on")
    assert backend.speed_note() is None  # a CPU: deterministic in either mode, nothing to say
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    monkeypatch.setattr(backend, "_configured", "on")
    assert "LITL_DETERMINISM=off" in backend.speed_note() and "3x slower" in backend.speed_note()
    monkeypatch.setattr(backend, "_configured", "off")
    assert backend.speed_note() is None
