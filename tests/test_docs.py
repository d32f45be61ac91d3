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
    # The report page's modules are checked by their anchors: `litl.report`'s own docstring
    # already mentions write_report in passing.
    pages = {"simulator": ["make_rollout"], "robots": ["DesignSpace"], "observers": ["register"],
             "loop": ["make_algorithm"], "cli": ["LoopConfig"],
             "report": ["replay", 'id="litl.report.summary.write_report"',
                        'id="litl.report.cli.main"', 'id="litl.pictures.draw_run"',
                        'id="litl.viz.saliency.animate_saliency"']}
    for page, names in pages.items():
        html = (tmp_path / "site" / page / "index.html").read_text()
        for name in names:
            assert name in html, (page, name)
