"""The API reference site builds from the docstrings with warnings as errors, with a page for the
simulator, robots, observers, loop, CLI and report."""

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_the_api_docs_build_without_warnings(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "WARNING" not in done.stderr, done.stderr[-3000:]
    pages = {"simulator": "make_rollout", "robots": "DesignSpace", "observers": "register",
             "loop": "make_algorithm", "cli": "LoopConfig", "report": "replay"}
    for page, name in pages.items():
        html = (tmp_path / "site" / page / "index.html").read_text()
        assert name in html, page
