import os
import pathlib

# XLA compilations are most of the suite's time, and several tests compile the same programs
# (a run, its killed copy in another process, its resumption). JAX's persistent cache lets them
# share: it is keyed by the compiled program, so a stale entry is never used. Subprocesses inherit
# the setting through the environment.
os.environ.setdefault(
    "JAX_COMPILATION_CACHE_DIR",
    str(pathlib.Path(__file__).resolve().parents[1] / ".pytest_cache" / "jax-compilation"),
)

# Every compilation is cached, the many sub-second ones included (JAX's default keeps only those
# over a second): each subprocess (CLI runs, notebooks, the killed run) compiles them otherwise.
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")

# The tests compile far more than they compute (tiny grids, short horizons), and on the CPU most of
# a compilation is LLVM's optimization of the generated code. Level 0 skips it: the programs compute
# the same things to rounding, compile in about half the time and run slower, up to twice as long
# for the few long simulations (the reference walker: 16 s -> 28 s; measured in
# docs/results/benchmarks.md, "The test suite's time"). A level already in XLA_FLAGS is kept.
_flags = os.environ.get("XLA_FLAGS", "")
if "xla_backend_optimization_level" not in _flags:
    _flags = f"{_flags} --xla_backend_optimization_level=0".strip()

os.environ["XLA_FLAGS"] = _flags

# Runs of the same robot and settings in one process share their compiled programs
# (`litl.loop.programs`); the tests keep more of them than a user's process does.
os.environ.setdefault("LITL_PROGRAM_CACHE", "16")

# litl before JAX starts: importing it asks XLA for deterministic GPU computations (litl.backend).
import jax  # noqa: E402
import pytest  # noqa: E402

import litl.backend  # noqa: E402

jax.config.update("jax_compilation_cache_dir", os.environ["JAX_COMPILATION_CACHE_DIR"])
jax.config.update(
    "jax_persistent_cache_min_compile_time_secs",
    float(os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"]),
)


@pytest.fixture
def deterministic():
    """For a test whose claim is bit-identity (a rerun, a resume, the same program twice): XLA
    computes deterministically on a CPU always, on a GPU only in litl's deterministic mode (the
    default; `LITL_DETERMINISM=off` turns it off, and then the test is skipped, not failed)."""
    if jax.default_backend() != "cpu" and litl.backend.mode() != "on":
        pytest.skip("bit-identity needs deterministic GPU computations: unset LITL_DETERMINISM=off")


@pytest.fixture
def x64():
    """Run the test with 64-bit floats enabled (gradient checks, reference scene)."""
    with jax.enable_x64(True):
        yield
