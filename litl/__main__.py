"""`python -m litl`: learning-in-the-loop co-design from the command line (Hydra).

    python -m litl                                   # the default demo (2D biped, a few minutes)
    python -m litl robot=arm observer=kmeans seeds=10
    python -m litl experiment=fig4b_biped            # a paper preset (see conf/experiment)
    python -m litl -m observer=vae,kmeans robot=biped,elephant   # a sweep
    python -m litl +scale=smoke                      # any run, shrunk to seconds

Outputs go to the Hydra run directory (printed at the start): metrics.jsonl, checkpoints/, final/,
task_loss.png, robot.gif and pictures of the learned representation.
"""

from __future__ import annotations

import os
import pathlib
import sys

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import OmegaConf

from litl.app import import_named_modules, run_experiment
from litl.conf.schema import from_hydra, register_with_hydra
from litl.errors import UserError, exit_on_user_error
from litl.loop.progress import say, set_label
from litl.loop.run_directory import RunDirectoryError
from litl.settings.old import translate_overrides


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def _main(cfg) -> None:
    hydra_config = HydraConfig.get()
    # A setting or a run directory litl cannot use: the message says which and what to do; a
    # traceback would only hide it (HYDRA_FULL_ERROR=1 still gets one).
    with exit_on_user_error("litl", keep_traceback=os.environ.get("HYDRA_FULL_ERROR") == "1", write=say):
        try:
            # Hydra's record of the job (its own writing is off: hydra.output_subdir is null),
            # written once this process owns the run directory, so a second run on it changes
            # nothing.
            config_files = {
                ".hydra/config.yaml": OmegaConf.to_yaml(cfg),
                ".hydra/hydra.yaml": OmegaConf.to_yaml({"hydra": hydra_config}),
                ".hydra/overrides.yaml": OmegaConf.to_yaml(list(hydra_config.overrides.task)),
            }
            if hydra_config.mode == RunMode.MULTIRUN:
                # Jobs of a sweep may run at once (joblib): each line says whose it is (Hydra's
                # launch lines give each job number's overrides).
                set_label(f"[job {hydra_config.job.num}] ")
            run_experiment(from_hydra(cfg), hydra_config.runtime.output_dir, config_files)
        except UserError as error:
            if not isinstance(error, RunDirectoryError):  # (that directory is another run's)
                _remove_if_unused(pathlib.Path(hydra_config.runtime.output_dir))
            raise


def _remove_if_unused(run_dir: pathlib.Path) -> None:
    """A run that failed before writing anything leaves no directory behind (nor empty parents
    up to the working directory); a directory holding anything but this process's lock file is
    kept."""
    if not run_dir.is_dir() or any(p.name != ".lock" for p in run_dir.iterdir()):
        return
    lock = run_dir / ".lock"
    if lock.exists():
        if lock.read_text().strip() != str(os.getpid()):
            return
        lock.unlink()
    stop = pathlib.Path.cwd().resolve()
    path = run_dir.resolve()
    while path != stop and stop in path.parents and not any(path.iterdir()):
        path.rmdir()
        path = path.parent


def main() -> None:
    # Keys that moved keep working, with a word on their new name (`litl.settings.old.MOVED_KEYS`).
    sys.argv[1:], messages = translate_overrides(sys.argv[1:])
    for message in messages:
        say(f"litl: warning: {message}")
    # Observers and controllers of the user's own register when their module is imported: before
    # the schema is built, so that their settings are keys like the built-ins'.
    with exit_on_user_error("litl", write=say):
        import_named_modules(sys.argv[1:])
    register_with_hydra()
    _main()


if __name__ == "__main__":
    main()
