"""The GPU check: one script a person with one GPU runs (well over 15 minutes on one H200).

    python benchmarks/gpu_check.py --out gpu_check            # the whole check
    python benchmarks/gpu_check.py --out /tmp/c --smoke       # tiny sizes: the script itself, on a CPU
    python benchmarks/gpu_check.py --out c --parts sim loop   # some parts only

Parts, each in fresh processes that run this checkout (PYTHONPATH is set to it):

  tests   `pytest -m gpu`: physics, gradients, determinism, kill-and-resume, a run of each observer
  sim     benchmarks/sim_speed.py (walker2d, walker2d_vmap10, block3d_1m) in each determinism mode
  loop    benchmarks/loop_speed.py, the biped at dx 1/128 with 10 seeds, in each determinism mode
  breakdown  benchmarks/loop_breakdown.py in litl's default mode: the bare simulation's
          forward+backward against whole iterations (no observer, k-means, VAE), dx 1/128, 10 seeds
  demo    the demo (3 episodes, no pictures) twice in litl's default mode: the final losses must be
          the same bit for bit
  p2g     benchmarks/p2g_scatter.py, the float scatter (`window`) against the fixed-point sum
          (`sim.particle_to_grid=fixed_point`, deterministic by construction), in each mode:
          whether the fixed-point sum without XLA's deterministic ops costs less than the
          scatter with them (the choice of litl's default on a GPU)

Determinism modes (`litl.backend`): `off` (LITL_DETERMINISM=off: XLA's defaults), `on` (litl's
default, `--xla_gpu_deterministic_ops=true`) with XLA's sort-based scatter rewrite switched off
(`on_no_sort`) and on (`on_sort`, `--xla_gpu_enable_scatter_determinism_expander=true`).

Writes OUT/gpu_check.json (every figure, the device, versions, each part's wall time) and
OUT/gpu_check.md (a short table: times per mode and their ratio to `off`). Exits non-zero when the
GPU tests fail or the two demo runs differ.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import re
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
PARTS = ("tests", "sim", "loop", "breakdown", "demo", "p2g")
EXPANDER = "--xla_gpu_enable_scatter_determinism_expander"
MODES = {
    "off": {"LITL_DETERMINISM": "off"},
    "on_no_sort": {"LITL_DETERMINISM": "on", "extra_flags": f"{EXPANDER}=false"},
    "on_sort": {"LITL_DETERMINISM": "on", "extra_flags": f"{EXPANDER}=true"},
}
PAPER_DX = 1 / 128


def _environment(mode: str | None = None) -> dict[str, str]:
    """This process's environment with the checkout first on PYTHONPATH, and `mode`'s switch and
    XLA flags added to the user's own."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    if mode is not None:
        settings = MODES[mode]
        env["LITL_DETERMINISM"] = settings["LITL_DETERMINISM"]
        extra = settings.get("extra_flags")
        if extra:
            env["XLA_FLAGS"] = f"{env.get('XLA_FLAGS', '')} {extra}".strip()
    return env


def _run(command: list[str], env: dict[str, str], timeout: float, cwd: pathlib.Path = ROOT) -> dict:
    """Run `command`; its exit code, wall time and the ends of its output (never raises)."""
    start = time.perf_counter()
    try:
        done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
        returncode, stdout, stderr = done.returncode, done.stdout, done.stderr
    except subprocess.TimeoutExpired as expired:
        returncode = "timeout"
        stdout = (
            (expired.stdout or b"").decode() if isinstance(expired.stdout, bytes) else expired.stdout or ""
        )
        stderr = (
            (expired.stderr or b"").decode() if isinstance(expired.stderr, bytes) else expired.stderr or ""
        )
    return {
        "command": " ".join(command),
        "returncode": returncode,
        "wall_s": round(time.perf_counter() - start, 1),
        "stdout": stdout,
        "stderr_tail": stderr[-3000:],
    }


def _last_json(stdout: str):
    lines = [line for line in stdout.strip().splitlines() if line.startswith(("{", "["))]
    return json.loads(lines[-1]) if lines else None


def check_tests(smoke: bool, timeout: float) -> dict:
    # One process (no xdist workers: each would reserve most of the GPU's memory), no notebooks.
    selection = ["tests/test_backend.py", "-k", "mode"] if smoke else []
    command = [sys.executable, "-m", "pytest", "-m", "gpu", "-q", "-o", "addopts=--durations=10"]
    result = _run(command + selection, _environment(), timeout)
    summary = re.findall(r"^=*\s*(.*\d+ (?:passed|failed).*?)\s*=*$", result["stdout"], re.M)
    return {
        "passed": result["returncode"] == 0,
        "summary": summary[-1] if summary else None,
        "wall_s": result["wall_s"],
        "output_tail": result["stdout"][-3000:] + result["stderr_tail"],
    }


def check_sim(smoke: bool, modes: list[str], timeout: float) -> dict:
    scenes = ["walker2d"] if smoke else ["walker2d", "walker2d_vmap10", "block3d_1m"]
    arguments = ["--scenes", *scenes, "--json", "--repeats", "2" if smoke else "3"]
    arguments += ["--steps", "20"] if smoke else []
    results = {}
    for mode in modes:
        result = _run(
            [sys.executable, str(BENCHMARKS / "sim_speed.py"), *arguments], _environment(mode), timeout
        )
        results[mode] = {"wall_s": result["wall_s"], "scenes": _last_json(result["stdout"])}
        if results[mode]["scenes"] is None:
            results[mode]["error"] = result["stderr_tail"]
    return results


def check_p2g(smoke: bool, modes: list[str], timeout: float) -> dict:
    sizes = ["biped64"] if smoke else ["biped64", "block128", "quadruped32", "quadruped64"]
    arguments = ["--sizes", *sizes, "--variants", "window", "fixed_point", "--json"]
    arguments += ["--repeats", "2" if smoke else "7"]
    results = {}
    for mode in modes[:1] if smoke else modes:  # smoke: the script itself, once
        command = [sys.executable, str(BENCHMARKS / "p2g_scatter.py"), *arguments]
        result = _run(command, _environment(mode), timeout)
        results[mode] = {"wall_s": result["wall_s"], "p2g": _last_json(result["stdout"])}
        if results[mode]["p2g"] is None:
            results[mode]["error"] = result["stderr_tail"]
    return results


def check_loop(smoke: bool, modes: list[str], timeout: float) -> dict:
    if smoke:
        arguments = ["--seeds", "2", "--dx", "0.03125", "--steps", "40", "--at-once", "2", "--repeats", "1"]
    else:
        arguments = ["--seeds", "10", "--dx", str(PAPER_DX), "--at-once", "10", "--repeats", "2"]
    results = {}
    for mode in modes:
        command = [sys.executable, str(BENCHMARKS / "loop_speed.py"), *arguments, "--json"]
        result = _run(command, _environment(mode), timeout)
        found = _last_json(result["stdout"])
        results[mode] = {"wall_s": result["wall_s"], "loop": found[0] if found else None}
        if found is None:
            results[mode]["error"] = result["stderr_tail"]
    return results


def check_breakdown(smoke: bool, timeout: float) -> dict:
    if smoke:
        arguments = ["--seeds", "1", "--dx", "0.03125", "--steps", "40", "--repeats", "1"]
    else:
        arguments = ["--seeds", "10", "--dx", str(PAPER_DX), "--repeats", "3"]
    command = [sys.executable, str(BENCHMARKS / "loop_breakdown.py"), *arguments, "--json"]
    result = _run(command, _environment(), timeout)
    found = _last_json(result["stdout"])
    return {
        "wall_s": result["wall_s"],
        "programs": found,
        **({} if found else {"error": result["stderr_tail"]}),
    }


def check_demo(smoke: bool, out: pathlib.Path, timeout: float) -> dict:
    overrides = ["+scale=smoke"] if smoke else ["loop.episodes=3"]
    overrides += ["output.pictures=false", "output.animation=false"]
    runs = []
    for attempt in (1, 2):
        command = [sys.executable, "-m", "litl", *overrides, f"hydra.run.dir={out / f'demo_{attempt}'}"]
        result = _run(command, _environment(), timeout, cwd=out)
        found = re.findall(r"final task loss per seed \[([^\]]*)\]", result["stderr_tail"] + result["stdout"])
        runs.append({"wall_s": result["wall_s"], "final_loss": found[-1] if found else None})
        if not found:
            runs[-1]["error"] = result["stderr_tail"]
    losses = [r["final_loss"] for r in runs]
    return {"runs": runs, "same": losses[0] is not None and losses[0] == losses[1]}


def _device() -> dict:
    done = _run(
        [
            sys.executable,
            "-c",
            "import json, litl, jax, jaxlib, flax; d = jax.devices()[0]; print(json.dumps({"
            "'platform': d.platform, 'device_kind': d.device_kind, 'device_count': jax.device_count(),"
            "'jax': jax.__version__, 'jaxlib': jaxlib.__version__, 'flax': flax.__version__}))",
        ],
        _environment(),
        300,
    )
    return _last_json(done["stdout"]) or {"error": done["stderr_tail"]}


def _ratio(value, base):
    return None if value is None or not base else round(value / base, 2)


def table(report: dict) -> str:
    """The short markdown table of gpu_check.json: times per mode and their ratio to `off`."""
    device = report["device"]
    lines = [
        f"GPU check on {device.get('device_kind')} ({device.get('platform')}), jax {device.get('jax')}, "
        f"jaxlib {device.get('jaxlib')}; {report['wall_s']:.0f} s in all.",
        "",
        "| what | " + " | ".join(report["modes"]) + " |",
        "|---|" + "---|" * len(report["modes"]),
    ]
    sim = report.get("sim", {})
    scenes = sorted({s for m in sim.values() for s in (m.get("scenes") or {})})
    for scene in scenes:
        for key in ("forward_s", "forward_backward_s"):
            cells = []
            base = ((sim.get("off") or {}).get("scenes") or {}).get(scene, {}).get(key)
            for mode in report["modes"]:
                value = ((sim.get(mode) or {}).get("scenes") or {}).get(scene, {}).get(key)
                cells.append("—" if value is None else f"{value:.4g} s (x{_ratio(value, base)})")
            lines.append(f"| {scene} {key} | " + " | ".join(cells) + " |")
    loop = report.get("loop", {})
    for key in ("optimize_s", "learn_s"):
        cells = []
        pick = lambda entry, key=key: (
            None if not entry else (min(entry[key].values()) if isinstance(entry[key], dict) else entry[key])
        )
        base = pick((loop.get("off") or {}).get("loop"))
        for mode in report["modes"]:
            value = pick((loop.get(mode) or {}).get("loop"))
            cells.append("—" if value is None else f"{value:.4g} s (x{_ratio(value, base)})")
        if loop:
            lines.append(f"| loop {key} (dx 1/128, 10 seeds) | " + " | ".join(cells) + " |")
    programs = (report.get("breakdown") or {}).get("programs") or []
    bare = next((p["median_s"] for p in programs if p["program"] == "rollout_fb"), None)
    for entry in programs:
        lines.append(
            f"| breakdown {entry['program']} ({entry['seeds']} seeds) | {entry['median_s']:.4g} s "
            f"(x{_ratio(entry['median_s'], bare)} of the bare simulation) |"
            + " |"
            * (len(report["modes"]) - 1)
        )
    if "tests" in report:
        tests = report["tests"]
        lines += ["", f"`pytest -m gpu`: {tests['summary']} ({tests['wall_s']:.0f} s)"]
    if "demo" in report:
        demo = report["demo"]
        finals = ", ".join(str(r["final_loss"]) for r in demo["runs"])
        lines.append(f"demo twice: final losses [{finals}], {'the same' if demo['same'] else 'DIFFERENT'}")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", type=pathlib.Path, required=True, help="folder for gpu_check.json/.md")
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS))
    parser.add_argument("--modes", nargs="+", choices=tuple(MODES), default=list(MODES))
    parser.add_argument("--smoke", action="store_true", help="tiny sizes: check the script on a CPU")
    parser.add_argument("--timeout", type=float, default=300, help="seconds allowed to each process")
    args = parser.parse_args(argv)
    if args.timeout <= 0:
        parser.error("--timeout must be positive")
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    report: dict = {"device": _device(), "modes": args.modes, "smoke": args.smoke}
    checks = {
        "tests": lambda: check_tests(args.smoke, args.timeout),
        "sim": lambda: check_sim(args.smoke, args.modes, args.timeout),
        "loop": lambda: check_loop(args.smoke, args.modes, args.timeout),
        "breakdown": lambda: check_breakdown(args.smoke, args.timeout),
        "demo": lambda: check_demo(args.smoke, out, args.timeout),
        "p2g": lambda: check_p2g(args.smoke, args.modes, args.timeout),
    }
    for part in PARTS:
        if part in args.parts:
            report[part] = checks[part]()
            # Written after each part: a check stopped from outside keeps the parts it finished.
            report["wall_s"] = round(time.perf_counter() - start, 1)
            (out / "gpu_check.json").write_text(json.dumps(report, indent=1))
            (out / "gpu_check.md").write_text(table(report))
    print(table(report))
    failed = ("tests" in report and not report["tests"]["passed"]) or (
        "demo" in report and not report["demo"]["same"]
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
