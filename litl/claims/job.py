"""`python -m litl.claims.job`: one slice of a claims cell, as a job of a Hydra multirun.

`python -m litl.claims --slice-seeds K` starts it over every slice still to run (`litl.claims.launch`);
by hand, with any launcher Hydra has:

    python -m litl.claims.job --multirun out=claims \\
        slice=paper/fig4b/vae/seeds-0-1,paper/fig4b/vae/seeds-2-3 \\
        hydra/launcher=submitit_slurm hydra.launcher.partition=cpu hydra.launcher.timeout_min=240

Each slice's run directory `OUT/runs/<slice>` must hold the `slice.json` that `litl.claims` wrote.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import pathlib
import sys

import hydra
from hydra.core.config_store import ConfigStore
from omegaconf import MISSING

from litl.errors import exit_on_user_error


@dataclasses.dataclass
class SliceJob:
    """out: the suite's --out; slice: ``<method>/<panel>/<variant>/seeds-<first>-<last>``;
    xla_threads: None (XLA's default, every core) or 1 (one thread: slices side by side on a CPU)."""

    out: str = MISSING
    slice: str = MISSING
    xla_threads: int | None = None


ConfigStore.instance().store(name="claims_slice", node=SliceJob)


@hydra.main(version_base="1.3", config_path=None, config_name="claims_slice")
def main(cfg: SliceJob) -> None:
    from litl.claims.launch import ONE_XLA_THREAD, run_slice

    if cfg.xla_threads == 1:  # read when JAX starts its CPU client, which has not happened yet
        os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {ONE_XLA_THREAD}".strip()
    for name in ("absl", "jax._src.xla_bridge", "matplotlib"):  # as `python -m litl` quiets them
        logging.getLogger(name).setLevel(logging.WARNING)
    with exit_on_user_error("python -m litl.claims.job", os_errors=True):
        run_slice(pathlib.Path(cfg.out), cfg.slice)


USAGE = """usage: python -m litl.claims.job [--multirun] out=OUT slice=METHOD/PANEL/VARIANT/seeds-F-L[,...]
                                 [xla_threads=1] [hydra/launcher=NAME hydra.launcher.KEY=VALUE ...]

Run (or resume) seed slices of a claims cell as the jobs of a Hydra multirun, each from the
slice.json that `python -m litl.claims --slice-seeds K` wrote into its run directory
OUT/runs/<slice>. `python -m litl.claims --slice-seeds K` starts it for you; by hand it takes any
Hydra launcher. Hydra's own help: --hydra-help.
"""


if __name__ == "__main__":
    if any(arg in ("-h", "--help") for arg in sys.argv[1:]):
        print(USAGE, end="")
        raise SystemExit(0)
    main()
