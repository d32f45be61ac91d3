"""A preset listed next to a result runs what made that result: `experiment=walkers3d` composes to
the settings of the commands behind the 3D walkers (docs/results/2026-11-26-3d-walkers.md), and
the README's rows name a preset or command of the method they report."""

import dataclasses
import pathlib
import re
import shlex

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "results" / "2026-11-26-3d-walkers.md"


def _page_commands() -> dict[str, list[str]]:
    """{robot: the Hydra overrides of its `python -m litl` command} from the page's first block."""
    block = re.search(r"```bash\n(.*?)```", PAGE.read_text(), re.S).group(1)
    commands = {}
    for line in block.splitlines():
        if not line.startswith("python -m litl "):  # (litl.replay and the gallery are not runs)
            continue
        words = shlex.split(line.split("#")[0])
        if words[:3] == ["python", "-m", "litl"]:
            overrides = [w for w in words[3:] if not w.startswith("hydra.")]
            robot = next(w.split("=", 1)[1] for w in overrides if w.startswith("robot="))
            commands[robot] = overrides
    return commands


def _settings(config) -> dict:
    """Everything that shapes the run (the run's name and its outputs aside)."""
    tree = dataclasses.asdict(config)
    return {key: value for key, value in tree.items() if key not in ("experiment", "output")}


def test_the_walkers3d_preset_is_the_pages_three_commands():
    from litl.app import compose

    commands = _page_commands()
    assert sorted(commands) == ["curved_quadruped", "hexapod", "quadruped"]
    for robot, overrides in commands.items():
        preset = compose(["experiment=walkers3d", f"robot={robot}"])
        measured = compose(overrides)
        assert _settings(preset) == _settings(measured), robot
        assert preset.method == "litl" and preset.experiment.name == measured.experiment.name


def test_the_walkers3d_sweep_is_the_three_robots():
    from omegaconf import OmegaConf

    preset = OmegaConf.load(ROOT / "litl" / "conf" / "experiment" / "walkers3d.yaml")
    robots = preset.hydra.sweeper.params.robot.split(",")
    assert robots == ["quadruped", "hexapod", "curved_quadruped"]
    assert set(robots) == set(_page_commands())


# The 3D walkers' distances per 1 s under method=litl (experiment=walkers3d,
# docs/results/2026-11-26-3d-walkers.md).
LITL_WALKER_DISTANCES = ("0.43", "0.37", "0.29")


@pytest.mark.parametrize("page", ["README.md", "docs/results/index.md"])
def test_the_fig6_rows_name_what_made_their_result(page):
    """The 3D walkers' measured row names the litl preset; fig6_demos (method=paper) is not
    presented as having made it."""
    rows = [line for line in (ROOT / page).read_text().splitlines() if line.startswith("| Fig. 6")]
    assert rows, f"{page} has no Fig. 6 row"
    for row in rows:
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        measured = re.search(r"\d\.\d\d per 1 s", cells[3])
        if "fig6_demos" in cells[1]:
            # Its own (method=paper) figures may stand there, never the walkers3d runs' distances.
            assert cells[2] == "paper", row
            shown = [d for d in LITL_WALKER_DISTANCES if re.search(rf"\b{re.escape(d)}\b", cells[3])]
            assert not shown, f"{page}: a fig6_demos row shows the method=litl runs' result {shown}"
            continue
        if measured:
            assert "experiment=walkers3d" in cells[1] and cells[2] == "litl", row
