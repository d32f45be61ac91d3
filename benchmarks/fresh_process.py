"""Run one measurement of a benchmark script in a fresh Python process (its own peak memory, no
compilation cached in memory from an earlier case) and read back the JSON it prints last."""

from __future__ import annotations

import json
import os
import subprocess
import sys


def measure_in_fresh_process(script: str, arguments: list[str], case: str) -> dict:
    """`python script *arguments` -> the dict its last stdout line holds; exits naming `case`
    with the end of its stderr if it fails."""
    done = subprocess.run(
        [sys.executable, script, *arguments], capture_output=True, text=True, env=os.environ.copy()
    )
    if done.returncode:
        raise SystemExit(f"{case} failed:\n{done.stderr[-4000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])
