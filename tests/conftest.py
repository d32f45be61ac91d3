import contextlib
import functools
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

# XLA's older CPU emitters compile in about half the time of the fusion emitters, XLA's default
# (the suite, back to back: 21 min -> 13.5 min on 2 cores; docs/results/benchmarks.md). They round some
# computations differently, within the tests' float32 tolerances; every bit-identity the tests
# claim (reruns, resumes, vmapped against sequential seeds) holds under them too. Only on the
# jaxlib they were measured with: an XLA that lacks a flag would refuse to start.
import jaxlib.version  # noqa: E402

_measured = jaxlib.version.__version__.startswith("0.10.")
if _measured and "xla_cpu_use_fusion_emitters" not in _flags:
    _flags = f"{_flags} --xla_cpu_use_fusion_emitters=false"

# XLA's CPU compiler also splits each program's generated code into parts it optimizes on several
# threads; with two workers on two cores those threads only contend. One part per program: the
# same computations, about 10% less CPU time (docs/results/benchmarks.md, 2026-11-29, later).
if _measured and "xla_cpu_parallel_codegen_split_count" not in _flags:
    _flags = f"{_flags} --xla_cpu_parallel_codegen_split_count=1"

os.environ["XLA_FLAGS"] = _flags

# Runs of the same robot and settings in one process share their compiled programs
# (`litl.loop.programs`); the tests keep more of them than a user's process does.
os.environ.setdefault("LITL_PROGRAM_CACHE", "16")

# litl before JAX starts: importing it asks XLA for deterministic GPU computations (litl.backend).
import jax  # noqa: E402
import pytest  # noqa: E402
from jax._src import core as jax_core  # noqa: E402  # trace_state_clean: not public

import litl.backend  # noqa: E402

jax.config.update("jax_compilation_cache_dir", os.environ["JAX_COMPILATION_CACHE_DIR"])
jax.config.update(
    "jax_persistent_cache_min_compile_time_secs",
    float(os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"]),
)


# XLA's default optimization level (what a user's runs compile at), for the tests marked
# `compute_bound`.
OPTIMIZED = {"xla_backend_optimization_level": 3}


@contextlib.contextmanager
def _compiled_for(item):
    """A test marked `compute_bound` runs long simulations of few programs (a 3D robot's 451
    steps, a float64 reference scene): level 0 above makes their code up to 27 times slower (the
    3D quadruped's rollout: 14.9 s against 0.54 s, for 0.9 s more compilation). Every `jax.jit`
    made while it sets up (its module's fixtures included) and runs compiles at XLA's default
    level, 3, instead (`compiler_options`; the persistent cache keys the two apart)."""
    if item.get_closest_marker("compute_bound") is None:
        yield
        return
    plain = jax.jit

    def optimized(fun, /, **kwargs):
        options = {**OPTIMIZED, **(kwargs.get("compiler_options") or {})}
        top = plain(fun, **{**kwargs, "compiler_options": options})
        nested = plain(fun, **kwargs)  # JAX takes compiler options only at the top level

        @functools.wraps(fun)
        def call(*args, **kwargs):
            return (top if jax_core.trace_state_clean() else nested)(*args, **kwargs)

        call.lower, call.trace, call.eval_shape = top.lower, top.trace, top.eval_shape
        return call

    jax.jit = optimized
    try:
        yield
    finally:
        jax.jit = plain


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item):
    with _compiled_for(item):
        return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    with _compiled_for(item):
        return (yield)


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
