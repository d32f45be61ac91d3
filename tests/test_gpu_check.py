"""benchmarks/gpu_check.py, the one script a person with a GPU runs: its table, and a cheap part of
it run for real on whatever device this is (the whole check is minutes even at its smoke size)."""

import importlib.util
import json
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("gpu_check", ROOT / "benchmarks" / "gpu_check.py")
gpu_check = importlib.util.module_from_spec(spec)
spec.loader.exec_module(gpu_check)


def test_the_table_gives_each_mode_its_ratio_to_off():
    scene = lambda fwd, bwd: {"walker2d": {"forward_s": fwd, "forward_backward_s": bwd}}
    loop = lambda opt, learn: {"loop": {"optimize_s": opt, "learn_s": {"10": learn}}}
    report = {
        "device": {"device_kind": "NVIDIA H100", "platform": "gpu", "jax": "0.11.2", "jaxlib": "0.11.2"},
        "modes": ["off", "on_no_sort", "on_sort"],
        "wall_s": 400.0,
        "sim": {
            "off": {"scenes": scene(0.02, 0.1)},
            "on_no_sort": {"scenes": scene(0.05, 0.3)},
            "on_sort": {},
        },
        "loop": {"off": loop(0.8, 2.0), "on_no_sort": loop(1.6, 2.2), "on_sort": loop(1.0, 2.0)},
        "tests": {"summary": "40 passed", "wall_s": 120.0},
        "demo": {"runs": [{"final_loss": "-0.25"}, {"final_loss": "-0.25"}], "same": True},
    }
    text = gpu_check.table(report)
    assert "| walker2d forward_backward_s | 0.1 s (x1.0) | 0.3 s (x3.0) | — |" in text
    assert "| loop optimize_s (dx 1/128, 10 seeds) | 0.8 s (x1.0) | 1.6 s (x2.0) | 1 s (x1.25) |" in text
    assert "demo twice: final losses [-0.25, -0.25], the same" in text
    report["demo"] = {"runs": [{"final_loss": "-0.25"}, {"final_loss": "-0.28"}], "same": False}
    assert "DIFFERENT" in gpu_check.table(report)


def test_the_modes_add_to_the_users_xla_flags(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_dump_to=/tmp/x")
    env = gpu_check._environment("on_sort")
    assert env["LITL_DETERMINISM"] == "on"
    assert env["XLA_FLAGS"] == "--xla_dump_to=/tmp/x --xla_gpu_enable_scatter_determinism_expander=true"
    assert gpu_check._environment("off")["LITL_DETERMINISM"] == "off"
    assert env["PYTHONPATH"].split(":")[0] == str(ROOT)


def test_the_script_runs_and_writes_its_json_and_table(tmp_path):
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "gpu_check.py"), "--out", str(tmp_path), "--smoke"]
        + ["--parts", "sim", "--modes", "off", "on_sort"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads((tmp_path / "gpu_check.json").read_text())
    assert set(report["sim"]) == {"off", "on_sort"}
    for mode, determinism in (("off", "off"), ("on_sort", "on")):
        walker = report["sim"][mode]["scenes"]["walker2d"]
        assert walker["forward_backward_s"] > 0
        assert walker["device"]["determinism"] == determinism
    assert "on_sort" in walker["device"]["xla_flags"] or "expander=true" in walker["device"]["xla_flags"]
    assert (tmp_path / "gpu_check.md").read_text().startswith("GPU check on ")
    bad = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "gpu_check.py"), "--out", str(tmp_path), "--parts", "gpu"],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "invalid choice: 'gpu'" in bad.stderr
