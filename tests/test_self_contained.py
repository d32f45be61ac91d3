"""A fresh clone stands on its own: no test, doc or module reads a path outside the checkout,
and the reference scene's test runs in a copy of the repository with nothing beside it."""

import json
import pathlib
import re
import shutil
import subprocess
import sys

import pytest

from tests.processes import child_environment

ROOT = pathlib.Path(__file__).resolve().parents[1]
# Spelled in pieces so that this file does not match its own patterns.
OUTSIDE = re.compile("|".join([r"\.\./" + "shared", "shared/" + "reference", "/" + "work/"]))
PARENTS = re.compile(r"parents\[(\d+)\]")


def _repository_files() -> list[pathlib.Path]:
    """The files a clone has: tracked ones and new ones a commit would add (not ignored)."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: the files a clone would hold are unknown")
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout.decode()
    return [ROOT / name for name in listed.split("\0") if name and (ROOT / name).is_file()]


def _text(path: pathlib.Path) -> str | None:
    try:
        return path.read_text()
    except (UnicodeDecodeError, OSError):
        return None  # a picture, an archive


def test_no_file_names_a_folder_beside_the_checkout():
    offenders = []
    for path in _repository_files():
        text = _text(path)
        if text is None or path == pathlib.Path(__file__).resolve():
            continue
        relative = path.relative_to(ROOT)
        offenders += [f"{relative}: {m.group()}" for m in OUTSIDE.finditer(text)]
        if path.suffix == ".py":
            # pathlib.Path(__file__).resolve().parents[k]: k = depth - 1 is the repository root.
            deepest = len(relative.parts) - 1
            offenders += [
                f"{relative}: parents[{m.group(1)}] climbs above the repository"
                for m in PARENTS.finditer(text)
                if int(m.group(1)) > deepest and "__file__" in text
            ]
    assert not offenders, "paths outside the checkout:\n" + "\n".join(offenders)


def test_the_reference_scene_is_a_fixture_of_the_repository():
    data = ROOT / "tests" / "sim" / "data"
    reference = json.loads((data / "walker2d.json").read_text())
    assert reference["n_particles"] == 2976
    for precision in ("float64", "float32"):
        assert {"loss", "grad_W", "grad_b", "mean_position_after_steps"} <= set(reference[precision])
    provenance = (data / "README.md").read_text()
    assert "DiffTaichi" in provenance and "diffmpm" in provenance
    assert "walker2d.md" in provenance and (data / "walker2d.md").is_file()


def test_a_copy_of_the_repository_alone_runs_the_reference_test(tmp_path):
    """The reference scene's float32 test in a copy of the checkout's files, in a folder with
    nothing beside it (the copy's own litl first on the path)."""
    clone = tmp_path / "clone"
    for path in _repository_files():
        target = clone / path.relative_to(ROOT)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(path, target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clone"]
    # The compilation cache conftest.py chose is kept (inherited): same programs, less time.
    environ = child_environment(clone)
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-o",
            "addopts=",
            "-p",
            "no:cacheprovider",
            "tests/sim/test_reference_walker.py::test_walker_float32_loss",
        ],
        cwd=clone,
        env=environ,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "1 passed" in done.stdout
