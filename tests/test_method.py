"""`method=paper|litl`: the paper's Algorithm 1 as written, and litl's; moved keys; the import
boundary of `litl.config`; the one base of the errors a user sees."""

import json
import math
import os
import subprocess
import sys
import warnings

import pytest

from litl.app import compose
from litl.config import Config, SettingsError, flatten, read_sections_only
from litl.errors import UserError
from litl.settings.old import MOVED_KEYS, translate_overrides, upgrade

# The paper's value of every key where litl's default differs (the paper, Sec. 4 and Fig. 3:
# the whole grid's velocities into a ReLU VAE, features only into the controller, gradients
# through everything, Algorithm 1 with no safeguards, early stopping in epochs), and litl's.
PAPER = {
    "observer.vae.window": None,
    "observer.vae.activation": "relu",
    "observer.vae.field": "velocity",
    "observer.pca.field": "velocity",
    "controller.mlp.period": None,
    "controller.mlp.feature_scale": 1.0,
    "controller.mlp.feature_gradient": "full",
    "loop.safeguards.gradient_clip": None,
    "loop.safeguards.update_tolerance": None,
    "loop.safeguards.step_back_tolerance": None,
    "loop.safeguards.final_learning_rate_fraction": 1.0,
    "loop.learning.max_steps": None,
    "loop.learning.patience_steps": None,
    "observer.vae.momentum_weight": 0.0,
    "loop.learning.learning_rate": 0.001,
    "loop.learning.patience": 20,
}
LITL = {
    "observer.vae.window": 0.5,
    "observer.vae.activation": "elu",
    "observer.vae.field": "mass_weighted",
    "observer.pca.field": "mass_weighted",
    "controller.mlp.period": 2 * math.pi / 30,
    "controller.mlp.feature_scale": 0.2,
    "controller.mlp.feature_gradient": "stop",
    "loop.safeguards.gradient_clip": 1.0,
    "loop.safeguards.update_tolerance": 0.1,
    "loop.safeguards.step_back_tolerance": 0.1,
    "loop.safeguards.final_learning_rate_fraction": 0.1,
    "loop.learning.max_steps": 320,
    "loop.learning.patience_steps": 100,
    "observer.vae.momentum_weight": 0.3,
    "loop.learning.learning_rate": 0.003,
    "loop.learning.patience": 5,
}
# litl's first reading of the paper (method=paper_first_reading, used until 2026-12-01): the
# paper's reading with litl's learning-phase step size and a patience of 5 epochs.
FIRST_READING = {**PAPER, "loop.learning.learning_rate": 0.003, "loop.learning.patience": 5}
PRESETS = (
    "fig4a_arm",
    "fig4b_biped",
    "fig4c_elephant",
    "fig4d_bunny",
    "fig5_recon",
    "fig6_demos",
    "fig8_latent",
    "table1_biped",
    "biped_compare",
    "walkers3d",
)
LITL_PRESETS = ("biped_compare", "walkers3d")  # the measured comparisons' own settings


def settings(config: Config) -> dict:
    """The run's settings, every observer's and controller's section included (run.json records
    the chosen one's only)."""
    recorded = ("method", "observer", "controller", "sim", "loop", "seeds", "seed")
    return {k: v for k, v in flatten(config.to_tree()).items() if k.split(".")[0] in recorded}


def test_the_first_reading_differs_from_the_paper_in_the_learning_phase_only():
    first = settings(compose(["method=paper_first_reading"]))
    paper = settings(compose(["method=paper"]))
    assert first["method"] == "paper_first_reading"
    assert {key: first[key] for key in FIRST_READING} == pytest.approx(FIRST_READING)
    assert sorted(k for k in paper if paper[k] != first[k]) == [
        "loop.learning.learning_rate",
        "loop.learning.patience",
        "method",
    ]


def test_method_paper_sets_every_key_to_the_papers_value():
    paper = settings(compose(["method=paper"]))
    assert paper["method"] == "paper"
    assert {key: paper[key] for key in PAPER} == pytest.approx(PAPER)
    # Nothing else moves: the paper's method differs from litl's in exactly these keys.
    litl = settings(compose([]))
    assert litl["method"] == "litl"
    assert {key: litl[key] for key in LITL} == pytest.approx(LITL)
    assert sorted(key for key in litl if litl[key] != paper[key]) == sorted([*PAPER, "method"])


def test_the_python_api_gives_the_same_methods_as_the_command_line():
    for method in ("paper", "litl"):
        assert settings(Config.for_method(method)) == settings(compose([f"method={method}"]))
    with pytest.raises(SettingsError, match="method='papr': choose one of"):
        Config.for_method("papr")


@pytest.mark.parametrize("preset", PRESETS)
def test_every_preset_names_its_method_and_says_which(preset):
    config = compose([f"experiment={preset}"])
    expected = "litl" if preset in LITL_PRESETS else "paper"
    assert config.method == expected
    assert f"method={expected}" in config.experiment.description
    # The command line switches a preset's method, and later single keys win over both.
    other = "paper" if expected == "litl" else "litl"
    switched = compose([f"experiment={preset}", f"method={other}", "loop.safeguards.gradient_clip=2.0"])
    assert switched.method == other and switched.loop.safeguards.gradient_clip == 2.0
    assert switched.loop.episodes == config.loop.episodes and switched.seeds == config.seeds


def test_moved_keys_still_work_with_a_word_on_their_new_name():
    with pytest.warns(FutureWarning) as heard:
        config = compose(["loop.replay=false", "observer.latent_dim=4"])
    assert [str(w.message).split(";")[0] for w in heard] == [
        "loop.replay is now loop.replay_buffer",
        "observer.latent_dim is now observer.vae.latent_dim",
    ]
    assert config.loop.replay_buffer is False and config.observer.vae.latent_dim == 4
    translated, messages = translate_overrides(["+loop.step_back_tolerance=0.3", "seeds=2"])
    assert translated == ["+loop.safeguards.step_back_tolerance=0.3", "seeds=2"]
    assert len(messages) == 1
    with pytest.warns(FutureWarning, match="controller.period is now controller.mlp.period"):
        config = Config().replace(controller={"period": None, "learning_rate": 0.2})
    assert config.controller.mlp.period is None and config.controller.learning_rate == 0.2
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the new spelling warns of nothing
        Config().replace(loop={"safeguards": {"gradient_clip": None}})


def test_an_older_run_json_reads_under_the_new_keys():
    """Older run.json files: moved keys, no method, no controller.module, and every built-in
    observer's and controller's section (until 2026-11-27; today only the chosen one's)."""
    old = json.loads(json.dumps(Config().run_settings()))
    every = Config().to_tree()
    old.pop("method")
    old["controller"].pop("module")
    old["controller"]["sinusoid"] = every["controller"]["sinusoid"]
    old["observer"]["kmeans"] = every["observer"]["kmeans"]
    old["observer"]["pca"] = every["observer"]["pca"]
    loop, observer = old["loop"], old["observer"]
    loop["replay"] = loop.pop("replay_buffer")
    loop["replay_capacity"] = loop.pop("buffer_capacity")
    loop.update(loop.pop("safeguards"))
    vae = observer.pop("vae")
    loop["learning"].update(beta=vae.pop("beta"), momentum_weight=vae.pop("momentum_weight"))
    observer.update(vae)
    observer["clusters"] = observer.pop("kmeans")["clusters"]  # k-means' one key then (no recluster)
    assert read_sections_only(upgrade(old)) == json.loads(json.dumps(Config().run_settings()))
    # Keys moved within their section, but for the VAE's loss weights, which left the loop's
    # learning phase for the observer's own section (2026-12-02).
    crossed = {old_key for old_key, new in MOVED_KEYS.items() if new.split(".")[0] != old_key.split(".")[0]}
    assert crossed == {"loop.learning.beta", "loop.learning.momentum_weight"}


def test_the_vaes_loss_weights_moved_to_its_own_section():
    """`loop.learning.momentum_weight` is now `observer.vae.momentum_weight`: on the command line
    and from the whole config with a warning; from the loop's section, refused with a message;
    an older run.json's values land in the observer's section."""
    with pytest.warns(
        FutureWarning, match="loop.learning.momentum_weight is now observer.vae.momentum_weight"
    ):
        assert compose(["loop.learning.momentum_weight=0.1"]).observer.vae.momentum_weight == 0.1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        assert Config().replace(loop={"learning": {"beta": 0.5}}).observer.vae.beta == 0.5
    with pytest.raises(ValueError, match="loop.learning.beta is now observer.vae.beta, outside loop"):
        Config().loop.replace(learning={"beta": 0.5})
    old = {"loop": {"learning": {"beta": 0.5, "momentum_weight": 0.0}}, "observer": {"kind": "vae"}}
    assert upgrade(old)["observer"]["vae"] == {"beta": 0.5, "momentum_weight": 0.0}


def test_every_old_spelling_leads_to_a_key_of_today():
    """`MOVED_KEYS` and the flat run.json layout's `FLAT_RUN_KEYS` point straight at today's
    keys (a setting or a section), never at another old spelling."""
    from litl.settings.old import FLAT_RUN_KEYS, current_key

    today = set(settings(Config()))
    sections = {key.rsplit(".", 1)[0] for key in today}
    for old_key, new in (*MOVED_KEYS.items(), *FLAT_RUN_KEYS.items()):
        assert new in today or new in sections, (old_key, new)
        assert current_key(old_key) == new and current_key(new) == new
    assert not set(MOVED_KEYS) & set(FLAT_RUN_KEYS)  # dotted and flat: two namespaces


def test_both_methods_share_the_ablation_switches_the_report_names_runs_by():
    """The report labels a run by how it departs from `LoopConfig()` in these switches; that is
    right for either method only while method=paper leaves them alone."""
    from litl.report.runs import ABLATIONS

    paper = flatten(json.loads(json.dumps(Config.for_method("paper").run_settings())))
    litl = flatten(json.loads(json.dumps(Config().run_settings())))
    for key, default, _ in ABLATIONS:
        assert paper[key] == litl[key] == default, key


def test_importing_the_config_imports_neither_jax_nor_the_loop():
    code = (
        "import sys, litl.config; bad = sorted(m for m in sys.modules if m == 'jax' or "
        "m.startswith(('jax.', 'litl.loop', 'litl.sim'))); print(bad); sys.exit(bool(bad))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_every_error_a_user_can_meet_has_one_base():
    from litl.loop.checkpoint import CheckpointError
    from litl.loop.run import RunDirectoryError
    from litl.replay import ReplayError
    from litl.report.runs import ReportError
    from litl.robots.catalog import UnknownRobotError
    from litl.robots.layout import LayoutError
    from litl.sim.config import SimConfigError
    from litl.sim.safety import SimulationError
    from litl.viz.robots import VizError

    for error in (
        SettingsError,
        CheckpointError,
        RunDirectoryError,
        ReplayError,
        ReportError,
        UnknownRobotError,
        LayoutError,
        SimConfigError,
        SimulationError,
        VizError,
    ):
        assert issubclass(error, UserError), error
    with pytest.raises(UserError, match="loop.alpha=2"):
        Config().replace(loop={"alpha": 2})


def test_an_older_run_json_gives_pca_the_field_it_read_then():
    """Until 2026-11-27 the PCA observer read the VAE's field (observer.vae.field)."""
    for method, field in (("paper", "velocity"), ("litl", "mass_weighted")):
        config = Config.for_method(method).replace(observer={"kind": "pca"})
        old = json.loads(json.dumps(config.run_settings()))
        del old["observer"]["pca"]["field"]
        old["observer"]["vae"] = config.to_tree()["observer"]["vae"]  # recorded then
        assert read_sections_only(upgrade(old)) == json.loads(json.dumps(config.run_settings()))
        assert upgrade(old)["observer"]["pca"]["field"] == field
