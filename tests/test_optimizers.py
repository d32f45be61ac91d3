"""`litl.optimizers`: every optimization method in one registry; CMA-ES and OpenAI-ES from evosax
on litl's controller and design, PPO from rejax on the robot as an environment; from the command
line to a run directory the report reads; their starts are litl's; a killed run resumes to the
same records; the old ``baseline=`` spellings; a user's method; bad input."""

import json
import sys

import jax
import numpy as np
import pytest

from litl.app import compose, run_experiment
from litl.config import SettingsError
from tests.guide import guide_block

SMOKE = [
    "optimizer=cmaes",
    "observer=kmeans",
    "+scale=smoke",
    "optimizer.cmaes.generations=2",
    "optimizer.cmaes.population=4",
]


@pytest.fixture(scope="module")
def cmaes_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("cmaes")
    config = compose([*SMOKE, "seeds=2", "output.progress=false"])
    return config, run_dir, run_experiment(config, run_dir)


def test_every_method_is_registered_and_the_preset_picks_an_observer_it_can_use():
    """optimizer=cmaes runs on k-means features unless the command line says otherwise; ppo on the
    environment's own observation; litl's loop is a method like the others, the default."""
    import litl.optimizers

    assert litl.optimizers.names() == ("litl", "cmaes", "sep_cmaes", "openai_es", "ppo")
    assert compose([]).optimizer.kind == "litl" and "optimizer" not in compose([]).run_settings()
    assert compose(["optimizer=cmaes"]).observer.kind == "kmeans"
    assert compose(["optimizer=cmaes", "observer=none"]).observer.kind == "none"
    assert compose(["optimizer=ppo"]).observer.kind == "none"


def test_the_old_baseline_spellings_still_work_with_a_message():
    with pytest.warns(FutureWarning, match="baseline=sep_cmaes is now optimizer=sep_cmaes"):
        config = compose(["baseline=sep_cmaes", "baseline.population=8", "baseline.generations=3"])
    assert config.optimizer.kind == "sep_cmaes" and config.optimizer.sep_cmaes.population == 8
    with pytest.warns(FutureWarning, match="baseline.ppo.timesteps is now optimizer.ppo.timesteps"):
        config = compose(["baseline=ppo", "baseline.learning_rate=0.001", "baseline.ppo.timesteps=4096"])
    assert config.optimizer.ppo.learning_rate == 0.001 and config.optimizer.ppo.timesteps == 4096
    with pytest.warns(FutureWarning):
        assert compose(["baseline=none"]).optimizer.kind == "litl"
    # cmaes never read the shared learning rate: said, not silently dropped.
    with pytest.raises(SettingsError, match="optimizer=cmaes has no 'learning_rate'; it is a key of"):
        compose(["baseline=cmaes", "baseline.learning_rate=0.1"])
    from litl.settings.old import upgrade

    old = {"kind": "cmaes", "population": 4, "generations": 2, "sigma": 0.1, "learning_rate": 0.03}
    assert upgrade({"baseline": old})["optimizer"] == {
        "kind": "cmaes",
        "module": None,
        "cmaes": {"population": 4, "generations": 2, "sigma": 0.1},
    }
    # A composed config of that time (.hydra/config.yaml) holds both old sections: each moves by
    # its own kind.
    both = upgrade({"world": {"kind": "slope", "angle": 12.0, "depth": 0.1}, "baseline": old})
    assert both["optimizer"]["cmaes"]["population"] == 4 and both["world"]["slope"] == {"angle": 12.0}
    assert upgrade({"world": {"kind": "flat"}, "baseline": {**old, "kind": "none"}})["optimizer"] == {
        "kind": "litl",
        "module": None,
    }


def test_a_cmaes_run_writes_a_run_directory_the_report_reads(cmaes_run):
    from litl.report import load_runs
    from litl.report.cli import main

    config, run_dir, done = cmaes_run
    settings = json.loads((run_dir / "run.json").read_text())
    assert settings["config"]["optimizer"] == {
        "kind": "cmaes",
        "module": None,
        "cmaes": {"population": 4, "generations": 2, "sigma": 0.1},  # its own section only
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
    algorithm = make_algorithm(build_robot(config), config.algorithm)
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
        ("optimizer.cmaes.population=1", "optimizer.cmaes.population=1: must be an integer >= 2"),
        ("optimizer.cmaes.generations=0", "optimizer.cmaes.generations=0: must be a positive integer"),
        ("optimizer.cmaes.sigma=0", "optimizer.cmaes.sigma=0.0: must be a positive number"),
        ("optimizer=sac", "sac"),
        ("optimizer.kind=sac", r"optimizer.kind='sac': unknown optimizer; choose one of \['litl', 'cmaes'"),
        ("optimizer=ppo optimizer.ppo.timesteps=0", "optimizer.ppo.timesteps=0: must be a positive integer"),
        (
            "optimizer=ppo optimizer.ppo.minibatches=3",
            "optimizer.ppo.minibatches=3: must divide an update's batch",
        ),
        (
            "optimizer=ppo optimizer.ppo.envs=4 optimizer.ppo.timesteps=8",
            "optimizer.ppo.timesteps=8: is less than",
        ),
        ("optimizer=ppo optimizer.ppo.gamma=0", "optimizer.ppo.gamma=0.0: must lie in"),
        (
            "optimizer=openai_es optimizer.openai_es.population=3",
            "optimizer.openai_es.population=3: must be even for openai_es",
        ),
        (
            "optimizer.openai_es.learning_rate=-1",
            "optimizer.openai_es.learning_rate=-1.0: must be a positive",
        ),
    ],
)
def test_bad_optimizer_settings_are_refused_naming_the_key(override, message):
    with pytest.raises(SettingsError, match=message):
        compose([*SMOKE, *override.split()])


@pytest.mark.parametrize("kind", ["openai_es", "sep_cmaes"])
def test_the_other_strategies_run_from_litls_start(kind, cmaes_run, tmp_path):
    """OpenAI-ES and separable CMA-ES: the same records; generation 0's loss is that of litl's
    initial parameters, as CMA-ES's is."""
    size = [f"optimizer.{kind}.generations=2", f"optimizer.{kind}.population=4"]
    config = compose([*SMOKE, f"optimizer={kind}", *size, "seeds=2", "output.progress=false"])
    done = run_experiment(config, tmp_path)
    assert [r["simulations"] for r in done["records"]] == [5, 5, 10, 10]
    assert json.loads((tmp_path / "run.json").read_text())["config"]["optimizer"]["kind"] == kind
    first = [r["task_loss"] for r in done["records"][:2]]
    assert first == [r["task_loss"] for r in cmaes_run[2]["records"][:2]]


def test_a_learning_observer_is_refused_before_anything_is_written(tmp_path):
    config = compose(["optimizer=cmaes", "observer=vae", "+scale=smoke"])
    with pytest.raises(SettingsError, match="observer 'vae' learns; use observer=kmeans or observer=none"):
        run_experiment(config, tmp_path / "run")
    assert not (tmp_path / "run" / "run.json").exists()
    assert jax.devices()  # the process is still usable


def test_a_killed_run_resumes_to_the_records_of_an_uninterrupted_one(cmaes_run, tmp_path, monkeypatch):
    """Checkpoints after every round (as a long run's are, every few minutes); the process dies in
    round 2; the same command resumes from the checkpoint and ends with the uninterrupted records."""
    import litl.optimizers.rounds as rounds
    from litl.optimizers.evolution import EvolutionStrategy

    config, _, done = cmaes_run
    config = config.replace(optimizer={"cmaes": {"generations": 3}})
    whole = run_experiment(config, tmp_path / "whole")
    monkeypatch.setattr(rounds, "CHECKPOINT_SECONDS", 0.0)
    advance = EvolutionStrategy.advance

    def dies_in_round_2(self, state, round_index):
        if round_index == 2:
            raise KeyboardInterrupt("killed")
        return advance(self, state, round_index)

    monkeypatch.setattr(EvolutionStrategy, "advance", dies_in_round_2)
    with pytest.raises(KeyboardInterrupt):
        run_experiment(config, tmp_path / "killed")
    assert len((tmp_path / "killed" / "metrics.jsonl").read_text().splitlines()) == 4
    monkeypatch.setattr(EvolutionStrategy, "advance", advance)
    resumed = run_experiment(config, tmp_path / "killed")
    strip = lambda records: [{k: v for k, v in r.items() if k != "wall_s"} for r in records]
    assert strip(resumed["records"]) == strip(whole["records"])
    on_disk = [json.loads(line) for line in (tmp_path / "killed" / "metrics.jsonl").read_text().splitlines()]
    assert strip(on_disk) == strip(whole["records"])
    other = config.replace(optimizer={"cmaes": {"sigma": 0.2}})
    with pytest.raises(Exception, match="other settings"):
        run_experiment(other, tmp_path / "killed")


PPO_SMOKE = [
    "optimizer=ppo",
    "+scale=smoke",
    "seeds=2",
    "optimizer.ppo.timesteps=128",
    "optimizer.ppo.envs=4",
    "optimizer.ppo.rollout=16",
    "optimizer.ppo.minibatches=4",
    "optimizer.ppo.epochs=2",
    "optimizer.ppo.evaluations=2",
    "output.progress=false",
]


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("ppo")
    config = compose(PPO_SMOKE)
    return config, run_dir, run_experiment(config, run_dir)


def test_a_ppo_run_writes_a_run_directory_the_report_reads(ppo_run):
    from litl.report import load_runs

    config, run_dir, done = ppo_run
    settings = json.loads((run_dir / "run.json").read_text())
    assert settings["config"]["optimizer"] == {
        "kind": "ppo",
        "module": None,
        "ppo": {
            "timesteps": 128,
            "envs": 4,
            "rollout": 16,
            "epochs": 2,
            "minibatches": 4,
            "hold": 8,
            "evaluations": 2,
            "gamma": 0.99,
            "normalize": True,
            "learning_rate": 3e-4,
        },
    }
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    # Round 0 evaluates the initial policy; two updates of 4 x 16 environment steps follow, one
    # per round (2 updates / 2 evaluations), each round ending in an evaluation.
    assert [(r["seed"], r["step"]) for r in records] == [(0, 0), (1, 0), (0, 1), (1, 1), (0, 2), (1, 2)]
    assert [r["environment_steps"] for r in records] == [0, 0, 64, 64, 128, 128]
    episode = 2 * 8  # an evaluation; smoke: 20 simulation steps, 2 whole actions of 8
    steps = [episode, 2 * episode + 64 * 8, 3 * episode + 128 * 8]
    assert [r["simulated_steps"] for r in records] == [n for n in steps for _ in (0, 1)]
    assert all(r["task_loss"] is not None for r in records)
    assert [run.head for run in load_runs(run_dir)] == ["ppo"]
    assert (run_dir / "checkpoints").is_dir() and json.loads((run_dir / "final.json").read_text()) == done[
        "final"
    ]


def test_ppos_task_loss_is_minus_the_return_rejax_measures_for_the_mean_action():
    """A round's task loss is its policy's mean action rolled out: rejax's own evaluation (its
    loop, gymnax's auto-resetting step) of the same policy gives minus it (10 actions, so that
    the loss stands well above float32's rounding)."""
    from rejax.evaluate import evaluate

    from litl.app import build_robot
    from litl.optimizers.ppo import PPOBaseline, mean_action

    config = compose([*PPO_SMOKE, "sim.steps=80"])
    method = PPOBaseline(build_robot(config), config.context(), config.optimizer.ppo)
    state = method.init()
    _, figures = method.advance(state, 0)
    one = jax.tree.map(lambda x: x[1], state)  # seed 1's initial agent
    algo = method.algo

    def act(obs, rng):
        obs = algo.normalize_obs(one.obs_rms_state, obs)
        return jax.numpy.clip(algo.actor.apply(one.actor_ts.params, obs[None], method=mean_action)[0], -1, 1)

    params = method.env_params
    assert params.max_steps == 10
    _, returns = evaluate(act, jax.random.key(0), method.env, params, 1, params.max_steps)
    assert abs(float(returns[0])) > 1e-5
    np.testing.assert_allclose(-float(returns[0]), float(figures["task_loss"][1]), rtol=1e-4)


def test_ppo_is_deterministic_and_refuses_an_observer(ppo_run, tmp_path):
    config, _, done = ppo_run
    again = run_experiment(config, tmp_path / "again")
    strip = lambda records: [{k: v for k, v in r.items() if k != "wall_s"} for r in records]
    assert strip(again["records"]) == strip(done["records"])
    with pytest.raises(SettingsError, match="optimizer=ppo observes the environment's particle summary"):
        run_experiment(compose([*PPO_SMOKE, "observer=kmeans"]), tmp_path / "observed")
    assert not (tmp_path / "observed" / "run.json").exists()


ONE_PLUS_ONE_MODULE = guide_block("environments.md", "# my_optimizers.py")


@pytest.fixture
def user_optimizers(tmp_path, monkeypatch):
    """The guide's module importable from tmp_path; the registry as it was afterwards."""
    import litl.optimizers

    (tmp_path / "my_optimizers.py").write_text(ONE_PLUS_ONE_MODULE)
    (tmp_path / "registers_nothing.py").write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(litl.optimizers.OPTIMIZERS, "_entries", dict(litl.optimizers.OPTIMIZERS._entries))
    yield tmp_path
    for name in ("my_optimizers", "registers_nothing"):
        sys.modules.pop(name, None)


def test_a_users_method_from_the_guide_runs_and_never_gets_worse(user_optimizers):
    base = ["optimizer=one_plus_one", "optimizer.module=my_optimizers", "observer=kmeans", "+scale=smoke"]
    config = compose([*base, "optimizer.one_plus_one.rounds=3", "seeds=2", "output.progress=false"])
    assert config.run_settings()["optimizer"] == {
        "kind": "one_plus_one",
        "module": "my_optimizers",
        "one_plus_one": {"rounds": 3, "sigma": 0.05},
    }
    run_dir = user_optimizers / "run"
    done = run_experiment(config, run_dir)
    losses = {seed: [r["task_loss"] for r in done["records"] if r["seed"] == seed] for seed in (0, 1)}
    for curve in losses.values():
        assert len(curve) == 3 and all(b <= a for a, b in zip(curve, curve[1:], strict=False))
    from litl.report import load_runs

    assert [run.head for run in load_runs(run_dir)] == ["one_plus_one"]
    with pytest.raises(SettingsError, match=r"^optimizer.one_plus_one.rounds=0: must be a positive integer"):
        compose([*base, "optimizer.one_plus_one.rounds=0"])
    with pytest.raises(SettingsError, match="optimizer.module='registers_nothing' registered no optimizer"):
        compose(["optimizer.kind=one_plus_two", "optimizer.module=registers_nothing"])
