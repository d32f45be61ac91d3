"""Each Python example of the README and the guide (docs/guide/*.md) runs as written, on its own,
and shows what it claims; the README stays a front page with the two commands; the commands of
the contributing page (docs/contributing.md) run.

`python -m litl` itself: tests/test_cli.py.
"""

import os
import pathlib
import re
import shlex
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
CONTRIBUTING = ROOT / "docs" / "contributing.md"
PAGES = [README, *sorted((ROOT / "docs" / "guide").glob("*.md")), CONTRIBUTING]
# (page, block) for every ```python block of the README, the guide and the contributing page.
BLOCKS = [
    (page, block) for page in PAGES for block in re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
]
# Every command of the contributing page's ```bash blocks, its comment cut.
COMMANDS = [
    line.split("  #")[0].strip()
    for block in re.findall(r"```bash\n(.*?)```", CONTRIBUTING.read_text(), re.S)
    for line in block.splitlines()
    if line.strip()
]


def run_block(first_line: str) -> dict:
    """Execute the one python block (README or guide) that starts with `first_line` in a fresh
    namespace."""
    found = [(page, block) for page, block in BLOCKS if block.startswith(first_line)]
    assert len(found) == 1, f"expected one python block starting {first_line!r}, found {len(found)}"
    page, block = found[0]
    namespace = {"__name__": "readme"}
    exec(compile(block, f"{page}:{first_line}", "exec"), namespace)
    return namespace


SIMULATING = "import jax, jax.numpy as jnp\nimport numpy as np"
OBSERVERS = "import jax, jax.numpy as jnp\nimport optax"
ROBOTS = "import tempfile\nimport jax.numpy as jnp"
SHAPES = "from litl.robots import Box"
PNG = "import tempfile\nfrom importlib import resources"
LOOP = "import tempfile\nimport litl.robots"
MODULE = "# my_robots.py"  # tests/robots/test_register.py and tests/test_cli.py run it
OBSERVER_MODULE = "# my_observers.py"  # tests/loop/test_observers.py runs it
WORLD_MODULE = "# my_worlds.py"  # tests/robots/test_world_registry.py runs it
OPTIMIZER_MODULE = "# my_optimizers.py"  # tests/test_optimizers.py runs it
ENVIRONMENTS = "import jax, jax.numpy as jnp\nimport litl.envs"
WORLD = "import dataclasses, math\nimport litl.robots"
SCENERY = "import dataclasses\nimport numpy as np\nimport litl.robots\nfrom litl.robots.scenery"
PPO_BLOCK = "import jax\nfrom rejax import PPO"
DESIGNS = "import litl.designs\nimport litl.robots"
# Indented in a list item of simulating.md; it goes on from the SIMULATING block's namespace.
MATERIALS = "  import dataclasses\n  from litl.sim.materials"


def test_every_block_is_checked():
    assert len(PAGES) > 1, "no guide pages found under docs/guide/"
    for page, block in BLOCKS:
        starts = [
            s
            for s in (
                SIMULATING,
                OBSERVERS,
                ROBOTS,
                SHAPES,
                PNG,
                LOOP,
                MODULE,
                OBSERVER_MODULE,
                WORLD_MODULE,
                OPTIMIZER_MODULE,
                ENVIRONMENTS,
                WORLD,
                SCENERY,
                MATERIALS,
                PPO_BLOCK,
                DESIGNS,
            )
            if block.startswith(s)
        ]
        assert len(starts) == 1, f"this python block of {page.name} has no test:\n{block[:200]}"


def test_readme_is_a_front_page_with_the_two_commands():
    text = README.read_text()
    assert len(text.splitlines()) <= 250, "README.md is the front page: the guide is docs/guide/"
    for marker, command in (
        ("<!-- run-command -->", ".venv/bin/python -m litl"),
        ("<!-- test-command -->", ".venv/bin/python -m pytest -q"),
    ):
        after = text.split(marker, 1)[1].lstrip()
        assert after.startswith("```bash\n"), marker
        assert after.split("\n")[1].endswith(command), marker


def test_the_contributing_page_commands_run():
    """The checks run as written and pass. A pytest command collects its tests (the suite cannot
    run inside itself); a benchmark parses its options with --help (running one takes minutes)."""
    python = ".venv/bin/python "
    kinds = set()
    # A clean environment for the inner pytest: none of this run's pytest/xdist variables.
    env = {key: value for key, value in os.environ.items() if not key.startswith("PYTEST_")}
    for command in COMMANDS:
        assert command.startswith(python), f"{CONTRIBUTING.name}: run from the .venv: {command}"
        args = shlex.split(command[len(python) :])
        if args[:2] == ["-m", "pytest"]:
            kinds.add("tests")
            args += ["--collect-only", "-p", "no:cacheprovider"]
        elif args[0].startswith("benchmarks/"):
            kinds.add("benchmarks")
            args = [args[0], "--help"]
        else:
            assert args[:2] in (["-m", "ruff"], ["-m", "mypy"]), f"a command without a rule: {command}"
            kinds.add("checks")
        done = subprocess.run(
            [sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600
        )
        assert done.returncode == 0, f"{command}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    assert kinds == {"checks", "tests", "benchmarks"}, kinds


def test_readme_and_guide_links_point_at_files():
    for page in PAGES:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
            if "://" not in target:
                assert (page.parent / target).exists(), f"{page.name} links to missing {target}"


def test_simulating_a_body_walks_and_has_gradients():
    ns = run_block(SIMULATING)
    assert ns["trajectory"].snapshots.shape == (10, 64, 64, 2)
    walked = float(ns["trajectory"].observations[-1, 0] - ns["trajectory"].observations[0, 0])
    assert walked > 0.01, f"the guide's body should walk right, moved {walked}"
    assert bool(jnp.isfinite(ns["value"]))
    assert abs(float(ns["d_amplitude"])) > 1e-5
    assert float(jnp.abs(ns["d_design"].youngs_modulus).sum()) > 1e-4


def test_materials_block_mixes_sand_into_the_guides_body():
    import textwrap

    ns = run_block(SIMULATING)
    ((page, block),) = [(p, b) for p, b in BLOCKS if b.startswith(MATERIALS)]
    exec(compile(textwrap.dedent(block), f"{page}:materials", "exec"), ns)
    assert ns["sandy"].materials[1].friction_angle == 30.0
    assert ns["final"].x.shape == ns["state"].x.shape
    assert bool(jnp.all(jnp.isfinite(ns["final"].x)))


def test_observers_block_trains_and_features():
    ns = run_block(OBSERVERS)
    snapshots = ns["trajectory"].snapshots
    assert snapshots.shape == (20, 64, 64, 2)
    assert float(jnp.abs(snapshots).max()) > 1e-3  # the field moves
    assert all(bool(jnp.isfinite(v)) for v in ns["losses"].values())
    # The block's train step trains: ten more of it on the same snapshots (a second of compute)
    # lower the loss at every step, by 1.8% in all (2026-12-05); Adam's small steps on one batch
    # and one key descend a smooth loss, and 1% is far above float32 rounding (1e-7).
    observer, opt_state, totals = ns["observer"], ns["opt_state"], [float(ns["losses"]["total"])]
    for _ in range(10):
        observer, opt_state, losses = ns["train_step"](observer, opt_state, snapshots, jax.random.key(2))
        totals.append(float(losses["total"]))
    assert np.all(np.diff(totals) < 0) and totals[-1] < 0.99 * totals[0], totals
    # The k-means features: each cluster's mean position (then velocity) of the final state.
    features, final = np.asarray(ns["features"]), ns["final"]
    assert features.shape == (2 * 6 * 2,)
    means = np.asarray(ns["baseline"].averaging) @ np.asarray(final.x)
    np.testing.assert_allclose(features[:12], means.reshape(-1), rtol=1e-5, atol=1e-6)


def test_robots_block_moves_and_draws():
    ns = run_block(ROBOTS)
    tmp = pathlib.Path(ns["tmp"])
    for picture in ("biped.png", "biped.gif"):
        assert (tmp / picture).stat().st_size > 1000
    positions = ns["positions"]
    assert positions.shape == (40, ns["robot"].layout.n_particles, 2)
    assert np.abs(ns["actuation"]).max() > 0.5
    assert np.abs(positions[-1] - positions[0]).max() > 0.02  # the legs move


def test_shapes_block_builds_a_robot():
    ns = run_block(SHAPES)
    assert ns["mine"].n_actuators == 2 and "head" in ns["mine"].layout.groups


def test_png_block_loads_the_rhino():
    ns = run_block(PNG)
    assert ns["rhino"].n_actuators == 8


def test_loop_block_runs():
    ns = run_block(LOOP)
    assert len(ns["result"].metrics) == 2 * 2 * 2
    assert ns["final"]["design"].shape == (2, 4)


def test_environments_block_steps_64_environments():
    namespace = run_block(ENVIRONMENTS)
    assert namespace["obs"].shape == (64, 8) and namespace["reward"].shape == (64,)
    assert bool(jnp.all(namespace["done"]))  # the episode's last step (then each reset)


@pytest.mark.compute_bound
def test_ppo_block_trains_rejax_ppo_on_a_litl_robot():
    namespace = run_block(PPO_BLOCK)
    returns = np.asarray(namespace["returns"])
    assert returns.shape == (3, 128) and np.all(np.isfinite(returns))
    # PPO trained: the mean return of the last evaluation's 128 episodes exceeds the untrained
    # policy's by 3 standard errors of the difference (statistics of the two means). Measured
    # 2026-12-05: 0.035 -> 0.081 -> 0.092, standard deviations about 0.06 (a rise of 7 of them).
    first, last = returns[0], returns[-1]
    error = np.sqrt(first.var(ddof=1) / len(first) + last.var(ddof=1) / len(last))
    assert last.mean() > first.mean() + 3 * error, returns.mean(axis=1)


def test_scenery_block_puts_a_lump_of_clay_beside_the_robot():
    namespace = run_block(SCENERY)
    robot, scene = namespace["robot"], namespace["scene"]
    own = robot.n_particles
    assert scene.state.x.shape[0] == own + robot.scenery[0].n_particles
    assert scene.body.material is not None and int(scene.body.material[own:].min()) == 1
    assert float(scene.state.x[own:, 0].min()) > float(scene.state.x[:own, 0].max())  # ahead of it


def test_world_block_builds_a_robot_with_its_colliders():
    namespace = run_block(WORLD)
    robot = namespace["robot"]
    (collider,) = robot.config.boundary.colliders
    assert collider.contact.friction == 0.6 and len(collider.shape.shapes) == 2


def test_designs_block_places_the_bipeds_muscles():
    namespace = run_block(DESIGNS)
    design, robot = namespace["design"], namespace["robot"]
    assert design.actuator_weights.shape == (robot.layout.n_particles, robot.n_actuators)
    summary = {k: float(v) for k, v in namespace["space"].summary(namespace["phi"]).items()}
    assert summary["placement/moved"] == 0.0 and 0 < summary["placement/actuated"] < 1
