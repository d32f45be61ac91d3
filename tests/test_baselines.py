"""`baseline=cmaes` (`litl.baselines`): CMA-ES from evosax on litl's controller and design, from
the command line to a run directory the report reads; its start is litl's; bad input."""

import json

import jax
import numpy as np
import pytest

from litl.app import compose, run_experiment
from litl.config import SettingsError

SMOKE = [
    "baseline=cmaes",
    "observer=kmeans",
    "+scale=smoke",
    "baseline.generations=2",
    "baseline.population=4",
]


@pytest.fixture(scope="module")
def cmaes_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("cmaes")
    config = compose([*SMOKE, "seeds=2", "output.progress=false"])
    return config, run_dir, run_experiment(config, run_dir)


def test_a_cmaes_run_writes_a_run_directory_the_report_reads(cmaes_run):
    from litl.report import load_runs
    from litl.report.cli import main

    config, run_dir, done = cmaes_run
    settings = json.loads((run_dir / "run.json").read_text())
    assert settings["config"]["baseline"] == {
        "kind": "cmaes",
        "population": 4,
        "generations": 2,
        "sigma": 0.1,
        "learning_rate": 0.03,
    }
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    assert [(r["seed"], r["step"]) for r in records] == [(0, 0), (1, 0), (0, 1), (1, 1)]
    assert [r["simulations"] for r in records] == [5, 5, 10, 10]  # population + 1 per generation
    assert all(r["simulated_steps"] == r["simulations"] * 20 for r in records)  # smoke: 20 steps
    final = json.loads((run_dir / "final.json").read_text())
    assert [f["seed"] for f in final] == [0, 1] and done["final"] == final
    runs = load_runs(run_dir)
    assert [run.head for run in runs] == ["cmaes"]
    assert main([str(run_dir)]) in (0, None)  # reported as any run
    assert "cmaes" in (run_dir / "summary.md").read_text()


def test_its_start_is_litls_and_it_is_deterministic(cmaes_run, tmp_path):
    """Generation 0's task loss is the loss of the strategy's mean before any update: litl's
    initial controller and design for that seed. The same command gives the same records."""
    from litl.app import build_robot
    from litl.loop import make_algorithm

    config, run_dir, done = cmaes_run
    algorithm = make_algorithm(build_robot(config), config)
    for seed in (0, 1):
        state = algorithm.init(seed)
        expected = float(algorithm.evaluate(state))
        first = next(r for r in done["records"] if r["seed"] == seed and r["step"] == 0)
        np.testing.assert_allclose(first["task_loss"], expected, rtol=1e-5, atol=1e-9)
    again = run_experiment(config, tmp_path / "again")
    assert again["records"] == [
        dict(r, wall_s=a["wall_s"]) for r, a in zip(done["records"], again["records"], strict=True)
    ]


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("baseline.population=1", "baseline.population=1: must be an integer >= 2"),
        ("baseline.generations=0", "baseline.generations=0: must be a positive integer"),
        ("baseline.sigma=0", "baseline.sigma=0.0: must be a positive number"),
        ("baseline=ppo", "ppo"),
        ("baseline=openai_es baseline.population=3", "baseline.population=3: must be even for openai_es"),
        ("baseline.learning_rate=-1", "baseline.learning_rate=-1.0: must be a positive number"),
    ],
)
def test_bad_baseline_settings_are_refused_naming_the_key(override, message):
    with pytest.raises(SettingsError, match=message):
        compose([*SMOKE, *override.split()])


def test_openai_es_runs_and_starts_from_litls_parameters(tmp_path):
    config = compose([*SMOKE, "baseline=openai_es", "output.progress=false"])
    done = run_experiment(config, tmp_path)
    assert [r["simulations"] for r in done["records"]] == [5, 10]
    assert json.loads((tmp_path / "run.json").read_text())["config"]["baseline"]["kind"] == "openai_es"


def test_a_learning_observer_is_refused_before_anything_is_written(tmp_path):
    config = compose(["baseline=cmaes", "observer=vae", "+scale=smoke"])
    with pytest.raises(SettingsError, match="observer 'vae' learns; use observer=kmeans or observer=none"):
        run_experiment(config, tmp_path / "run")
    assert not (tmp_path / "run" / "run.json").exists()
    assert jax.devices()  # the process is still usable
