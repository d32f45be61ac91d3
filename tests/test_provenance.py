"""Which litl made a run: run.json's provenance, resuming by another commit, the claims suite's
refusal to mix commits or materials in one cell, and `method=paper`'s elastic material."""

import json
import pathlib
import platform
import re
import shutil
import subprocess

import pytest

import litl
from litl.loop.run_directory import RunDirectoryError, claim
from litl.records import provenance

ROOT = pathlib.Path(__file__).resolve().parent.parent


def test_the_record_names_litl_its_commit_and_the_processor(monkeypatch):
    recorded = provenance.record()
    assert recorded["litl"] == litl.__version__
    if (ROOT / ".git").exists():  # tests run from a checkout (CI: a fresh clone)
        assert re.fullmatch(r"[0-9a-f]{40}", recorded["commit"])
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True)
        assert recorded["commit"] == head.stdout.strip()
        assert isinstance(recorded["dirty"], bool)
    cpu = recorded["processor"]
    assert cpu["machine"] == platform.machine()
    assert set(cpu["extensions"]) <= set(provenance.X86_EXTENSIONS)
    # The cap on XLA's instruction set is read from XLA_FLAGS as the process has them.
    provenance.processor.cache_clear()
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_max_isa=AVX2 --xla_gpu_deterministic_ops=true")
    assert provenance.processor()["xla_cpu_max_isa"] == "AVX2"
    provenance.processor.cache_clear()


def _git(repo, *args):
    subprocess.run(
        ["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t", *args],
        check=True,
        capture_output=True,
    )


def test_a_checkout_gives_its_commit_and_whether_tracked_files_changed(tmp_path):
    assert provenance.checkout(tmp_path) == (None, None)  # not a checkout: a pip-installed litl
    _git(tmp_path, "init", "-q")
    (tmp_path / "tracked.py").write_text("a = 1\n")
    _git(tmp_path, "add", "tracked.py")
    _git(tmp_path, "commit", "-q", "-m", "one")
    provenance.checkout.cache_clear()
    commit, dirty = provenance.checkout(tmp_path)
    assert re.fullmatch(r"[0-9a-f]{40}", commit) and dirty is False
    (tmp_path / "outputs").mkdir()  # run outputs are untracked: still clean
    (tmp_path / "outputs" / "run.json").write_text("{}")
    provenance.checkout.cache_clear()
    assert provenance.checkout(tmp_path) == (commit, False)
    (tmp_path / "tracked.py").write_text("a = 2\n")
    provenance.checkout.cache_clear()
    assert provenance.checkout(tmp_path) == (commit, True)
    provenance.checkout.cache_clear()


def test_describe_says_which_litl_for_people():
    assert provenance.describe({"litl": "0.1.0", "commit": "a" * 40, "dirty": True}) == (
        "litl 0.1.0, commit aaaaaaaaaaaa (uncommitted changes)"
    )
    assert provenance.describe({"litl": "0.1.0", "commit": None, "dirty": None}) == "litl 0.1.0"
    assert "not recorded" in provenance.describe(None)


def test_a_resume_with_another_strain_limit_names_the_one_it_was_made_with(tmp_path):
    wanted = {"robot": "biped", "max_stretch": None, "material": {"max_stretch": float("inf")}, "config": {}}
    made = {**wanted, "max_stretch": 3.0, "material": {"max_stretch": 3.0}}
    (tmp_path / "run.json").write_text(json.dumps(made))
    before = (tmp_path / "run.json").read_text()
    with pytest.raises(RunDirectoryError, match=r"made with robot.material.max_stretch=3.0\).*Nothing was"):
        claim(tmp_path, {**wanted, "observer": {}}, {})
    assert (tmp_path / "run.json").read_text() == before


def test_method_paper_simulates_the_papers_elastic_material_unless_told_otherwise():
    from litl.app import build_robot, compose
    from litl.config import Config

    assert build_robot(compose([])).config.max_stretch == 3.0  # litl's 2D material yields at 3
    assert build_robot(compose(["method=paper"])).config.max_stretch is None
    assert build_robot(compose(["experiment=fig4b_biped", "+scale=smoke"])).config.max_stretch is None
    assert (
        build_robot(compose(["experiment=fig4b_biped", "method=litl", "+scale=smoke"])).config.max_stretch
        == 3.0
    )
    assert build_robot(compose(["method=paper", "robot.material.max_stretch=2.5"])).config.max_stretch == 2.5
    assert Config.for_method("paper").robot.material.max_stretch == float("inf")  # the Python API too
    # The time step is the material's, not the limit's.
    assert build_robot(compose(["method=paper"])).config.dt == build_robot(compose([])).config.dt


# --- the claims suite: one commit and one material per cell ---------------------------------


def _cell_run(run_dir: pathlib.Path, commit: str | None, max_stretch, records: int = 0) -> None:
    run_dir.mkdir(parents=True)
    recorded = None if commit is None else {"litl": "0.1.0", "commit": commit, "dirty": False}
    config = {"seeds": 2, "loop": {"episodes": 1, "iterations": 1}}
    saved = {"config": config, "max_stretch": max_stretch, **({"provenance": recorded} if recorded else {})}
    (run_dir / "run.json").write_text(json.dumps(saved))
    (run_dir / "metrics.jsonl").write_text("{}\n" * records)


@pytest.fixture
def smoke_cells():
    from litl.app import compose
    from litl.claims.suite import SCALES, cells

    suite = cells(["fig4b"], ["litl", "paper"])
    configs = {}

    def config_of(cell):
        if cell.name not in configs:
            configs[cell.name] = compose(
                [*cell.overrides(SCALES["smoke"], 2), "loop.episodes=1", "loop.iterations=1"]
            )
        return configs[cell.name]

    return suite, config_of


def test_a_cell_started_by_another_commit_or_material_is_not_resumed(tmp_path, smoke_cells, monkeypatch):
    from litl.claims.origins import check_resumable
    from litl.claims.suite import ClaimsError

    suite, config_of = smoke_cells
    monkeypatch.setattr(provenance, "checkout", lambda root=None: ("c" * 40, False))
    vae = suite[0]  # litl/fig4b/vae
    _cell_run(vae.run_dir(tmp_path), "d" * 40, 3.0)
    before = (vae.run_dir(tmp_path) / "run.json").read_text()
    with pytest.raises(
        ClaimsError,
        match=r"litl/fig4b/vae .*started by litl 0.1.0, commit dddddddddddd; this is "
        r"litl 0.1.0, commit cccccccccccc.*Nothing was changed",
    ):
        check_resumable(tmp_path, suite, config_of)
    assert (vae.run_dir(tmp_path) / "run.json").read_text() == before
    # A run from before provenance was recorded is another litl too.
    shutil.rmtree(vae.run_dir(tmp_path))
    _cell_run(vae.run_dir(tmp_path), None, 3.0)
    with pytest.raises(ClaimsError, match="version not recorded"):
        check_resumable(tmp_path, suite, config_of)
    # The same commit with the paper's elastic material where litl's limit was asked for.
    shutil.rmtree(vae.run_dir(tmp_path))
    _cell_run(vae.run_dir(tmp_path), "c" * 40, None)
    with pytest.raises(
        ClaimsError,
        match=r"material that elastic \(no strain limit\); this suite asks for one "
        r"that yields past a stretch of 3",
    ):
        check_resumable(tmp_path, suite, config_of)
    # A finished cell is only read: never refused.
    (vae.run_dir(tmp_path) / "metrics.jsonl").write_text("{}\n" * 2)
    paper_vae = next(c for c in suite if c.name == "paper/fig4b/vae")
    _cell_run(paper_vae.run_dir(tmp_path), "c" * 40, None)  # the paper's material: resumable
    check_resumable(tmp_path, suite, config_of)


def test_a_claims_table_names_the_commits_and_materials_of_its_cells(tmp_path, smoke_cells):
    from litl.claims.origins import describe, origins

    suite, _ = smoke_cells
    _cell_run(suite[0].run_dir(tmp_path), "a" * 40, 3.0)
    _cell_run(suite[1].run_dir(tmp_path), "a" * 40, 3.0)
    paper = [c for c in suite if c.method == "paper"]
    _cell_run(paper[0].run_dir(tmp_path), "a" * 40, None)
    lines = describe(origins(tmp_path, suite))
    assert lines == [
        "Made by litl 0.1.0, commit aaaaaaaaaaaa.",
        "Material: yields past a stretch of 3 (litl); elastic (no strain limit) (paper).",
    ]
    _cell_run(paper[1].run_dir(tmp_path), "b" * 40, None)
    lines = describe(origins(tmp_path, suite))
    assert lines[0] == "Made by 2 versions of litl (their verdicts mix programs):"
    assert lines[2] == "- litl 0.1.0, commit bbbbbbbbbbbb: paper/fig4b/kmeans"


def test_a_horizon_other_than_the_committed_plans_is_allowed_and_said():
    from litl.app import compose
    from litl.claims.plan import COMMITTED_PLANS, PAPER_PLAN, STAGE2_PLAN, departure_from_plan

    planned = compose(["experiment=fig4b_biped", "loop.episodes=10", "seeds=10"])
    assert departure_from_plan(planned) is None
    longer = compose(["experiment=fig4b_biped"])  # the preset's 20 x 10
    note = departure_from_plan(longer)
    assert note is not None and "20 episodes x 10 iterations" in note and PAPER_PLAN.page in note
    assert (ROOT / PAPER_PLAN.page).exists()  # the plan it names is committed
    # The second stage's seeds 10-29 were planned; the same size from another first seed was not.
    stage2 = compose(["experiment=fig4b_biped", "loop.episodes=10", "seeds=20", "seed=10"])
    assert departure_from_plan(stage2) is None
    elsewhere = compose(["experiment=fig4b_biped", "loop.episodes=10", "seeds=20", "seed=30"])
    note = departure_from_plan(elsewhere)
    assert note is not None and "seeds 30-49" in note and STAGE2_PLAN.page in note
    assert all((ROOT / plan.page).exists() for plan in COMMITTED_PLANS)


def test_a_paper_method_run_made_with_the_strain_limit_resumes_as_it_was_made(tmp_path, capsys):
    """method=paper yielded at 3 from 2026-11-26 to 2026-11-27: such a run resumes with its limit."""
    from litl.app import compose, run_experiment

    overrides = ["method=paper", "+scale=smoke", "observer=kmeans", "seeds=1", "loop.episodes=2",
                 "loop.iterations=1", "sim.steps=40", "output.pictures=false", "output.animation=false",
                 "output.progress=false"]  # fmt: skip
    made = compose([*overrides, "robot.material.max_stretch=3", "loop.episodes=1"])
    run_experiment(made, tmp_path)
    today = (tmp_path / "run.json").read_text()
    saved = json.loads(today)
    del saved["provenance"]  # as a run.json written before litl recorded provenance
    saved["config"]["loop"]["episodes"] = 2
    (tmp_path / "run.json").write_text(json.dumps(saved))
    capsys.readouterr()
    result = run_experiment(compose(overrides), tmp_path)
    assert "made before 2026-11-27 with the strain limit (max_stretch 3.0); it resumes with it" in (
        capsys.readouterr().err
    )
    assert len(result.metrics) == 2 and json.loads((tmp_path / "run.json").read_text())["max_stretch"] == 3.0
    # A run with provenance is today's: the same difference is refused, nothing changed.
    other = tmp_path / "today"
    other.mkdir()
    (other / "run.json").write_text(today)
    before = (other / "run.json").read_text()
    with pytest.raises(RunDirectoryError, match="robot.material.max_stretch=3.0"):
        run_experiment(compose(overrides), other)
    assert (other / "run.json").read_text() == before
