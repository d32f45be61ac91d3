"""The documentation site builds with warnings as errors: the guide (docs/guide/), the dated results
(docs/results/) and the API reference from the docstrings, with a page for the simulator, robots,
observers, loop, CLI and report (docs/api/), and the contributing page (docs/contributing.md)."""

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_the_docs_build_without_warnings(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "WARNING" not in done.stderr, done.stderr[-3000:]
    # The report page's modules are checked by their anchors: `litl.report`'s own docstring
    # already mentions write_report in passing.
    pages = {
        "simulator": ["make_rollout"],
        "robots": ["DesignSpace"],
        "observers": ["register"],
        "loop": ["make_algorithm"],
        "cli": ["LoopConfig"],
        "report": [
            "replay",
            'id="litl.report.summary.write_report"',
            'id="litl.report.cli.main"',
            'id="litl.viz.run_pictures.draw_run"',
            'id="litl.viz.saliency.animate_saliency"',
        ],
    }
    for page, names in pages.items():
        html = (tmp_path / "site" / "api" / page / "index.html").read_text()
        for name in names:
            assert name in html, (page, name)
    # Every guide and results page is built, and the navigation shows the three sections.
    for section in ("guide", "results"):
        for source in (ROOT / "docs" / section).glob("*.md"):
            name = "" if source.stem == "index" else source.stem
            assert (tmp_path / "site" / section / name / "index.html").exists(), source
    assert (tmp_path / "site" / "contributing" / "index.html").exists()
    home = (tmp_path / "site" / "index.html").read_text()
    for section in ("Guide", "Results", "API"):
        assert section in home, section
