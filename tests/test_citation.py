"""How to cite litl and the paper: CITATION.cff, and the same entries as BibTeX in the README and
on the documentation's home page."""

import pathlib
import re
import tomllib

import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAPER_AUTHORS = [
    ("Spielberg", "Andrew"),
    ("Zhao", "Allan"),
    ("Hu", "Yuanming"),
    ("Du", "Tao"),
    ("Matusik", "Wojciech"),
    ("Rus", "Daniela"),
]


def _citation() -> dict:
    return yaml.safe_load((ROOT / "CITATION.cff").read_text())


def _bibtex(page: pathlib.Path) -> str:
    section = page.read_text().split("## Citing", 1)
    assert len(section) == 2, f"{page.name} has no 'Citing' section"
    blocks = re.findall(r"```bibtex\n(.*?)```", section[1], re.S)
    assert len(blocks) == 1, f"{page.name}: expected one BibTeX block under 'Citing'"
    return blocks[0]


def test_citation_cff_names_litl_and_the_paper():
    citation = _citation()
    assert citation["cff-version"] == "1.2.0"
    for key in ("message", "title", "authors", "version", "license"):
        assert citation[key], key
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert str(citation["version"]) == project["version"], "CITATION.cff's version is the package's"
    (paper,) = citation["references"]
    assert paper["title"].startswith("Learning-In-The-Loop Optimization: End-To-End Control")
    assert [(a["family-names"], a["given-names"]) for a in paper["authors"]] == PAPER_AUTHORS
    assert paper["year"] == 2019 and "NeurIPS 2019" in paper["collection-title"]


def test_readme_and_home_page_give_the_same_bibtex_as_the_citation_file():
    readme, home = _bibtex(ROOT / "README.md"), _bibtex(ROOT / "docs" / "index.md")
    assert readme == home
    paper = _citation()["references"][0]
    entry = readme.split("@software", 1)[0]
    authors = re.search(r"author\s*=\s*\{(.*?)\},", entry, re.S).group(1)
    assert [a.strip() for a in " ".join(authors.split()).split(" and ")] == [
        f"{family}, {given}" for family, given in PAPER_AUTHORS
    ]
    title = re.search(r"title\s*=\s*\{(.*?)\},", entry, re.S).group(1)
    assert " ".join(title.split()) == " ".join(paper["title"].split())
    assert "NeurIPS 2019" in entry and "year      = {2019}" in entry
    assert f"version = {{{_citation()['version']}}}" in readme
