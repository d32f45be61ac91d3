"""Which litl made a run, and on which processor: what a cited result must name.

`record()` is what a run directory keeps in `run.json` under "provenance": litl's version; where
litl is imported from a git checkout, its commit and whether the checkout had uncommitted changes
to tracked files; and the processor (its model and the instruction-set extensions that XLA's CPU
code may use). Float32 results depend on the last: XLA compiles for the processor it runs on, so
the same command rounds differently on another CPU model (docs/guide/gpu.md). A pip-installed
litl (no checkout) records its version and a null commit.
"""

from __future__ import annotations

import functools
import os
import pathlib
import platform
import re
import subprocess
from typing import Any

# The x86 extensions that change what XLA:CPU may emit (vector width, FMA, dot-product and AMX
# instructions), in the order of `--xla_cpu_max_isa`'s levels; other flags do not matter to it.
X86_EXTENSIONS = (
    "sse4_2",
    "avx",
    "avx2",
    "fma",
    "avx512f",
    "avx512bw",
    "avx512dq",
    "avx512vl",
    "avx512_vnni",
    "avx512_bf16",
    "avx512_fp16",
    "avx_vnni",
    "amx_tile",
    "amx_bf16",
    "amx_int8",
)
_MAX_ISA = re.compile(r"--xla_cpu_max_isa=(\S+)")


def record() -> dict[str, Any]:
    """run.json's "provenance": {"litl", "commit", "dirty", "processor"}."""
    from litl import __version__

    commit, dirty = checkout()
    return {"litl": __version__, "commit": commit, "dirty": dirty, "processor": processor()}


@functools.cache
def checkout(root: pathlib.Path | None = None) -> tuple[str | None, bool | None]:
    """(commit, dirty) of the git checkout at `root` (default: the one litl is imported from);
    (None, None) where litl is not in one (a pip-installed copy) or git is not available.
    `dirty`: tracked files differ from the commit (untracked files, such as run outputs, do not
    count)."""
    root = pathlib.Path(__file__).resolve().parents[2] if root is None else root
    if not (root / ".git").exists():  # a checkout's root (.git is a file in a worktree)
        return None, None
    try:
        commit = _git(root, "rev-parse", "HEAD")
        changes = _git(root, "status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None, None
    return commit, bool(changes)


def _git(root: pathlib.Path, *args: str) -> str:
    result = subprocess.run(
        ["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10, check=True
    )
    return result.stdout.strip()


@functools.cache
def processor() -> dict[str, Any]:
    """{"machine", "model", "extensions", "xla_cpu_max_isa"}: the architecture, the CPU's model
    name, its instruction-set extensions that XLA:CPU may use (x86: `X86_EXTENSIONS` it has;
    elsewhere empty), and the cap `--xla_cpu_max_isa` puts on them (None: none)."""
    model, flags = _cpuinfo()
    match = _MAX_ISA.findall(os.environ.get("XLA_FLAGS", ""))
    return {
        "machine": platform.machine(),
        "model": model or platform.processor() or None,
        "extensions": [name for name in X86_EXTENSIONS if name in flags],
        "xla_cpu_max_isa": match[-1] if match else None,
    }


def _cpuinfo() -> tuple[str | None, set[str]]:
    """The first CPU's model name and flags from /proc/cpuinfo (Linux; elsewhere none)."""
    try:
        text = pathlib.Path("/proc/cpuinfo").read_text()
    except OSError:
        return None, set()
    model: str | None = None
    flags: set[str] = set()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip()
        if key in ("model name", "Model") and model is None:
            model = value.strip()
        elif key in ("flags", "Features") and not flags:
            flags = set(value.split())
    return model, flags


def describe(recorded: dict[str, Any] | None) -> str:
    """One line for people: ``litl 0.1.0, commit 1a2b3c4d5e6f (uncommitted changes)``; for a run
    from before provenance was recorded, says so."""
    if not recorded:
        return "litl version not recorded (a run from before 2026-11-27)"
    commit = recorded.get("commit")
    text = f"litl {recorded.get('litl')}"
    if commit:
        text += f", commit {commit[:12]}" + (" (uncommitted changes)" if recorded.get("dirty") else "")
    return text
