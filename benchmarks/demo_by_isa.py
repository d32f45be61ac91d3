"""Which XLA:CPU settings move the demo's final task loss on this processor?

    python benchmarks/demo_by_isa.py --out demo_by_isa.json
    python benchmarks/demo_by_isa.py --flags "" "--xla_cpu_max_isa=AVX2"

Runs the README's quick demo (`python -m litl`, pictures off) once per set of XLA_FLAGS, each in a
fresh process, and prints the final task loss it ends with, its wall time and this processor
(`litl.records.provenance.processor`). The demo's co-design amplifies float32 rounding, so the last
digits of its number tell apart programs that XLA compiled differently: flags that leave the
number unchanged did not change the program on this processor. Compare the table across machines
to see which digits hold.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

import litl  # noqa: F401  (as every benchmark: XLA's determinism flag, litl.backend)
from litl.records import provenance

DEFAULT_FLAGS = (
    "",
    "--xla_cpu_max_isa=AVX2",
    "--xla_cpu_max_isa=SSE4_2",
    "--xla_cpu_max_isa=AVX2 --xla_cpu_enable_platform_dependent_math=false",
    "--xla_cpu_max_isa=AVX2 --xla_cpu_use_xnnpack=false --xla_cpu_use_onednn=false",
)
_FINAL = re.compile(r"final task loss per seed \[([^\]]+)\]")


def run_demo(flags: str, root: pathlib.Path) -> dict:
    """The demo under `flags` (added to XLA_FLAGS) in its own process: its final loss and time."""
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    if flags:
        env["XLA_FLAGS"] = flags
    with tempfile.TemporaryDirectory() as run_dir:
        start = time.perf_counter()
        done = subprocess.run(
            [sys.executable, "-m", "litl", f"hydra.run.dir={run_dir}", "output.progress=false",
             "output.pictures=false", "output.animation=false"],
            cwd=root, env=env, capture_output=True, text=True, check=False,
        )  # fmt: skip
        seconds = time.perf_counter() - start
    found = _FINAL.search(done.stdout + done.stderr)
    if done.returncode or not found:
        raise SystemExit(f"the demo failed under XLA_FLAGS={flags!r}:\n{done.stderr[-2000:]}")
    return {"xla_flags": flags, "final_task_loss": float(found.group(1)), "wall_s": round(seconds, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--flags", nargs="+", default=list(DEFAULT_FLAGS), help="XLA_FLAGS sets to try")
    parser.add_argument("--out", type=pathlib.Path, default=None, help="write the table as JSON here")
    args = parser.parse_args()
    root = pathlib.Path(__file__).resolve().parents[1]
    cpu = provenance.processor()
    print(f"processor: {cpu['model']} ({cpu['machine']}; {' '.join(cpu['extensions'])})")
    rows = []
    for flags in args.flags:
        row = run_demo(flags, root)
        rows.append(row)
        print(f"  {row['final_task_loss']:+.6f}  {row['wall_s']:6.1f} s  XLA_FLAGS={flags!r}", flush=True)
    if args.out:
        args.out.write_text(json.dumps({"processor": cpu, "runs": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
