"""What litl asks of JAX's backend: the same numbers on every run, and a fast GPU scatter.

On a GPU, XLA sums particle-to-grid scatter-adds with atomics and picks kernels by autotuning, so
the same program gives different float32 roundings from one run to the next; a seed's curve could
not be reproduced and a resumed run would not equal an uninterrupted one. litl therefore asks XLA
for deterministic GPU computations (`--xla_gpu_deterministic_ops=true`) unless the user opts out,
with one switch for every way into litl (the CLI, `litl.claims`, `litl.replay`, `litl.gradcheck`,
the benchmarks, `import litl` in a notebook):

    LITL_DETERMINISM=on    # the default: deterministic GPU computations
    LITL_DETERMINISM=off   # XLA's defaults: faster on some GPUs, different roundings each run

The switch acts through `XLA_FLAGS`, which XLA reads once, when JAX's backend starts; `import
litl` sets it (adding to the user's own `XLA_FLAGS`, never replacing them), so it must come
before the first JAX computation of the process. A CPU computes deterministically in either mode.
A user who sets `--xla_gpu_deterministic_ops` in `XLA_FLAGS` themselves decides the mode that way;
set both, and they must agree.
"""

from __future__ import annotations

import os
import re
import sys
import warnings

from litl.errors import UserError

SWITCH = "LITL_DETERMINISM"
# Where litl notes the flag it added to XLA_FLAGS: a child process inherits both, and its own
# LITL_DETERMINISM then decides (litl's addition is not the user's word).
ADDED = "LITL_XLA_FLAG_ADDED"
MODES = ("on", "off")
XLA_FLAG = "--xla_gpu_deterministic_ops"
# jaxlib versions whose CUDA float32 scatter-add is a compare-and-swap loop (jax-ml/jax#38806).
SLOW_CUDA_SCATTER = ((0, 10, 2), (0, 11, 0))

_FLAG_PATTERN = re.compile(re.escape(XLA_FLAG) + r"(?:=(\S*))?(?:\s|$)")
_TRUE, _FALSE = ("true", "1", "yes", ""), ("false", "0", "no")


class DeterminismError(UserError):
    """`LITL_DETERMINISM` has a value litl does not know, or contradicts the user's XLA_FLAGS."""


def requested_mode(environ=None) -> tuple[str, str]:
    """The determinism mode the environment asks for, and who asked.

    Returns:
      (mode, source): mode "on" or "off"; source "LITL_DETERMINISM", "XLA_FLAGS" or "default".

    Raises:
      DeterminismError: an unknown value of LITL_DETERMINISM or of the XLA flag, or the two
        set to opposite modes.
    """
    environ = os.environ if environ is None else environ
    switch = environ.get(SWITCH)
    if switch is not None and switch.strip().lower() not in MODES:
        raise DeterminismError(
            f"{SWITCH}={switch!r} is not a mode litl knows: use {SWITCH}=on (deterministic GPU "
            f"computations, the default) or {SWITCH}=off (XLA's faster, run-to-run varying ones)."
        )
    from_flags = _mode_in_xla_flags(_users_flags(environ))
    if switch is None:
        return (from_flags, "XLA_FLAGS") if from_flags else ("on", "default")
    switch = switch.strip().lower()
    if from_flags and from_flags != switch:
        raise DeterminismError(
            f"{SWITCH}={switch} contradicts XLA_FLAGS, which sets "
            f"{XLA_FLAG}={'true' if from_flags == 'on' else 'false'}: remove one of the two, or "
            f"make them agree."
        )
    return switch, SWITCH


def _mode_in_xla_flags(xla_flags: str) -> str | None:
    matches = _FLAG_PATTERN.findall(xla_flags)
    if not matches:
        return None
    value = matches[-1].strip().lower()  # XLA keeps the last occurrence of a flag
    if value in _TRUE:
        return "on"
    if value in _FALSE:
        return "off"
    raise DeterminismError(f"XLA_FLAGS sets {XLA_FLAG}={value!r}: XLA expects true or false.")


def _users_flags(environ) -> str:
    """XLA_FLAGS without the flag litl added to them (in this or a parent process)."""
    flags = environ.get("XLA_FLAGS", "").split()
    added = environ.get(ADDED)
    if added and added in flags:
        del flags[len(flags) - 1 - flags[::-1].index(added)]
    return " ".join(flags)


_configured: str | None = None


def configure(environ=None) -> str:
    """Set XLA_FLAGS for the requested mode (called by `import litl`); returns the mode.

    Adds `--xla_gpu_deterministic_ops=true` to the user's XLA_FLAGS in mode "on" (keeping every
    flag they set); in mode "off" adds nothing. Warns when JAX's GPU backend already started
    without the flag, since XLA reads its flags only once.
    """
    global _configured
    environ = os.environ if environ is None else environ
    mode, _ = requested_mode(environ)
    had_flag = XLA_FLAG in environ.get("XLA_FLAGS", "")
    flags = _users_flags(environ)
    environ.pop(ADDED, None)
    if mode == "on" and _mode_in_xla_flags(flags) is None:
        environ["XLA_FLAGS"] = f"{flags} {XLA_FLAG}=true".strip()
        environ[ADDED] = f"{XLA_FLAG}=true"
    elif flags or "XLA_FLAGS" in environ:
        environ["XLA_FLAGS"] = flags
    if environ is os.environ:
        _configured = mode
    if mode == "on" and not had_flag and _gpu_backend_started():
        warnings.warn(
            "JAX's GPU backend started before litl was imported, so XLA did not see "
            f"{XLA_FLAG}=true and this process's GPU computations are not deterministic. "
            "Import litl before the first JAX computation (or restart the kernel), or set "
            f"XLA_FLAGS={XLA_FLAG}=true yourself.",
            stacklevel=3,
        )
    return mode


def _gpu_backend_started() -> bool:
    if "jax" not in sys.modules:
        return False
    from jax._src import xla_bridge  # private: whether backends exist, without starting them

    backends = getattr(xla_bridge, "_backends", {}) or {}
    return any(name in ("cuda", "rocm", "gpu") for name in backends)


def mode() -> str:
    """The determinism mode of this process: "on" or "off", as `import litl` set it (XLA reads its
    flags once, so a later change of the environment does not change it)."""
    return _configured if _configured is not None else requested_mode()[0]


def speed_note() -> str | None:
    """The line a run on an accelerator prints in litl's deterministic mode: what it costs
    there and how to lift it (None on a CPU, which is deterministic either way, or when off)."""
    import jax

    if jax.default_backend() == "cpu" or mode() != "on":
        return None
    return (
        "litl: deterministic GPU computations, the same numbers on every run (measured about 3x "
        "slower on an H200 at dx 1/128); LITL_DETERMINISM=off when you do not need them"
    )


def record() -> dict:
    """What a run directory records of the backend it ran on (run.json's "backend")."""
    import jax
    import jaxlib

    return {
        "determinism": mode(),
        "platform": jax.default_backend(),
        "device": jax.devices()[0].device_kind,
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
    }


def device_of(recorded: dict | None) -> str | None:
    """The device a run ran on, from its `record()` (run.json's "backend"): the device's name
    (``NVIDIA H200``), else the platform (``cpu``); None where neither was recorded."""
    found = (recorded or {}).get("device") or (recorded or {}).get("platform")
    return None if found is None else str(found)


_warned_slow_scatter = False


def warn_if_slow_gpu_scatter() -> None:
    """Warn once per process when JAX runs on a CUDA GPU with a jaxlib whose float32 scatter-add
    (particle-to-grid) is the slow compare-and-swap loop, naming the fix."""
    global _warned_slow_scatter
    if _warned_slow_scatter:
        return
    import jax
    import jaxlib

    if jax.default_backend() != "gpu" or not _is_cuda(jax.devices()[0]):
        return
    if not SLOW_CUDA_SCATTER[0] <= _version(jaxlib.__version__) <= SLOW_CUDA_SCATTER[1]:
        return
    _warned_slow_scatter = True
    warnings.warn(
        f"jaxlib {jaxlib.__version__} compiles float32 scatter-add on CUDA GPUs into a slow "
        "compare-and-swap loop (jax-ml/jax#38806), and particle-to-grid is that pattern: "
        'install jax 0.11.1 or later, `pip install -U "jax[cuda12]>=0.11.1"` (litl\'s cuda '
        "extra asks for it).",
        stacklevel=2,
    )


def _is_cuda(device) -> bool:
    platform_version = getattr(getattr(device, "client", None), "platform_version", "") or ""
    return "cuda" in platform_version.lower() or "nvidia" in device.device_kind.lower()


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r"\d+", text)[:3])
