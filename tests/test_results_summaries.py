"""The README's and the results index's verdict figures equal those on the pages they link to.

A results page may be re-judged (a correction, or a new page judging its records again); the
summaries that repeat its figures must follow, or a stale summary stays behind. Pure text parsing,
nothing is run.

**Rows checked.** Every row of README.md's "What the results show" table, every row of
docs/results/index.md's per-figure table ("The paper's results") and every bullet of its
"Beyond the paper" and "Pages" lists.

**Figures a row states** (its verdict figures):

- Holm p-values: ``Holm p X``, ``Holm p X and Y``, ``Holm p X, Y`` (each number after "Holm p",
  joined by "," or "and");
- Holm family sizes: ``Holm over N``, ``over the table's N`` (or the suite's / the page's),
  ``over the N of [page]``.

**Which page a figure is checked against.** A row is cut into clauses at its cells ("|") and at
each ";" outside brackets and parentheses. A figure is checked against the results pages
(``docs/results/*.md``, relative links resolved) linked in its own clause; a clause linking none
borrows the links of the next clause of its cell that has some (a citation follows what it
supports), else of the previous one. A plan page (``*-plan.md``) holds no verdicts and is not a
source. A page a later page re-judged (``REJUDGED``: the same records, judged again under new rules
or a new family) stands for its re-judging, so a summary citing it must state the re-judged
figures; the index's "Pages" list is exempt, each item describing its page as dated. A figure
that no link reaches is an error unless the row is in ``SKIPPED``.

**What a page prints**, besides its own text: every ``claims.md`` or ``claims.csv`` under
docs/assets/ the page links to, and the ``claims.csv`` beside a linked ``claims.md``. In the text
a value written ``old → new`` (or a family "from A to B") counts as its new value only.

- A page's Holm p-values: the numbers after "Holm p" / "Holm-adjusted p" (joined by "," or
  "and"), the number in "Holm X over", every number (outside square brackets) in a table column
  whose header holds "Holm" and "p", and a claims.csv's ``holm_p`` column.
- A page's family sizes: ``Holm over N``, ``over the table's / suite's / page's N``, ``over each
  table's N tests``, ``over the N`` (followed by "tests", "comparisons" or punctuation),
  ``family of N``, ``(N tests)``, ``the suite's N tests``, N in a table column headed "family",
  with N in digits or a word ("three"); and the number of rows of a linked claims.csv that carry
  a Holm p (all its rows where it has no ``holm_p`` column): Holm's family is each table's.

**Matching at the row's precision.** A row's p-value matches when some p-value of the page,
rounded as the row writes its number, gives the row's number: "5e-7" (one significant figure)
matches 5.1e-7 and 5.06e-07; "0.008" (three decimals) matches 0.0077; "0.30" matches 0.303. A row's
family size N matches when the page states N as a family (above). A figure is not paired with its
claim: a changed figure that equals another Holm p (or family) of the same pages still passes."""

from __future__ import annotations

import csv
import dataclasses
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
ASSETS = ROOT / "docs" / "assets"

# Rows whose figures are not checked: (source file, the row's start) -> why. Kept short.
SKIPPED: dict[tuple[str, str], str] = {}

# Pages whose verdicts a later page judged again (the records unchanged, the rules or the family
# new): a summary citing one states the re-judging's figures. The index's list of pages is exempt:
# each of its items describes its page as dated.
REJUDGED = {
    "2026-11-26-claims-suite.md": "2026-12-02-claims-rejudged.md",
    "2026-11-26-elephant-10x10.md": "2026-12-02-claims-rejudged.md",
    "2026-11-27-claims-rejudged.md": "2026-12-02-claims-rejudged.md",
    "2026-11-27-claims-dx128.md": "2026-12-02-claims-rejudged.md",
}

NUM = r"\d+(?:\.\d+)?(?:[eE][-−+]?\d+)?"
WORDS = {
    "two": 2,
    "three": 3,
    "four": 4,
    "five": 5,
    "six": 6,
    "seven": 7,
    "eight": 8,
    "nine": 9,
    "ten": 10,
    "eleven": 11,
    "twelve": 12,
    "thirteen": 13,
    "fourteen": 14,
}
COUNT = r"(\d+|" + "|".join(WORDS) + r")"


@dataclasses.dataclass
class Row:
    source: str  # the file the row is in, relative to the repository
    label: str  # the row's start, to name it
    text: str


@dataclasses.dataclass
class Figure:
    kind: str  # "p" or "family"
    value: str  # as the row writes it
    clause: str


def _number(text: str) -> float:
    return float(text.replace("−", "-"))


def _count(text: str) -> int:
    return WORDS[text] if text in WORDS else int(text)


def matches_at_precision(row_value: str, page_value: float) -> bool:
    """Whether the page's value, rounded as the row writes its number, gives the row's number."""
    row_value = row_value.replace("−", "-")
    target = float(row_value)
    mantissa, _, exponent = row_value.lower().partition("e")
    if exponent:
        digits = len(mantissa.replace(".", "").lstrip("0")) or 1
        rounded = float(f"{page_value:.{digits - 1}e}")
    else:
        decimals = len(mantissa.partition(".")[2])
        rounded = round(page_value, decimals)
    return abs(rounded - target) <= 1e-12 * max(1.0, abs(target))


# --- the rows -----------------------------------------------------------------------------------


def _section(text: str, heading: str) -> str:
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == heading)
    level = heading.split()[0]
    end = next(
        (
            i
            for i in range(start + 1, len(lines))
            if lines[i].startswith("#") and lines[i].split()[0] in {level, level[:-1]} | {"#"}
        ),
        len(lines),
    )
    return "\n".join(lines[start + 1 : end])


def table_rows(text: str, heading: str, source: str) -> list[Row]:
    """The body rows of the tables under ``heading`` (header and rule left out)."""
    rows = []
    header_next = True
    for line in _section(text, heading).splitlines():
        if not line.startswith("|"):
            header_next = True
            continue
        if header_next or set(line.replace("|", "").strip()) <= set("-: "):
            header_next = False
            continue
        label = line.strip("|").split("|")[0].strip()
        rows.append(Row(source, label, line))
    return rows


def bullet_rows(text: str, heading: str, source: str) -> list[Row]:
    """The items of the bullet lists under ``heading``, continuation lines joined."""
    rows: list[Row] = []
    for line in _section(text, heading).splitlines():
        if line.startswith("- "):
            rows.append(Row(source, line[2:62], line[2:]))
        elif line.startswith("  ") and rows:
            rows[-1].text += " " + line.strip()
    return rows


def clauses(text: str) -> list[list[str]]:
    """Each cell's clauses: cut at "|" and at ";" outside brackets, parentheses and backticks."""
    cells: list[list[str]] = [[]]
    current: list[str] = []
    depth = 0
    code = False
    for char in text:
        if char == "`":
            code = not code
        elif not code and char in "([":
            depth += 1
        elif not code and char in ")]":
            depth = max(0, depth - 1)
        if not code and depth == 0 and char in "|;":
            cells[-1].append("".join(current))
            current = []
            if char == "|":
                cells.append([])
            continue
        current.append(char)
    cells[-1].append("".join(current))
    return [[c for c in cell if c.strip()] for cell in cells if any(c.strip() for c in cell)]


LINK = re.compile(r"\]\(([^)\s#]+)(?:#[^)\s]*)?\)")


def linked_pages(clause: str, base: pathlib.Path, rejudged: dict[str, str]) -> list[pathlib.Path]:
    """The results pages a clause links to (a plan holds no verdicts: not one), re-judged ones
    replaced by the page that re-judged them."""
    pages = []
    for target in LINK.findall(clause):
        if "://" in target:
            continue
        path = (base / target).resolve()
        if path.parent != RESULTS.resolve() or path.suffix != ".md" or path.name == "index.md":
            continue
        if path.stem.endswith("-plan"):
            continue
        path = path.with_name(rejudged.get(path.name, path.name))
        if path not in pages:
            pages.append(path)
    return pages


ROW_P = re.compile(rf"Holm p ({NUM}(?:(?:, | and ){NUM})*)")
ROW_FAMILY = re.compile(
    r"Holm over (?:the )?(?:\w+'s )?(\d+)|over the (?:table|suite|page)'s (\d+)|over the (\d+) of"
)


def row_figures(clause: str) -> list[Figure]:
    figures = []
    for group in ROW_P.findall(clause):
        for value in re.findall(NUM, group):
            figures.append(Figure("p", value, clause))
    for groups in ROW_FAMILY.findall(clause):
        figures.append(Figure("family", next(g for g in groups if g), clause))
    return figures


# --- what a page prints -------------------------------------------------------------------------


@dataclasses.dataclass
class Printed:
    p: list[float]
    families: set[int]


def _markdown_tables(text: str) -> list[tuple[list[str], list[list[str]]]]:
    tables = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("|") and i + 1 < len(lines) and re.match(r"^\|[-:| ]+\|$", lines[i + 1]):
            header = [c.strip() for c in lines[i].strip().strip("|").split("|")]
            body = []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                body.append([c.strip() for c in lines[i].strip().strip("|").split("|")])
                i += 1
            tables.append((header, body))
        else:
            i += 1
    return tables


PAGE_P = re.compile(rf"Holm(?:-adjusted)? p\s*=?\s*({NUM}(?:(?:, | and ){NUM})*)")
PAGE_P_OVER = re.compile(rf"Holm ({NUM}) over")
PAGE_FAMILY = [
    re.compile(rf"Holm(?:'s correction)? over (?:the |each )?(?:[\w-]+'s )?{COUNT}\b"),
    re.compile(rf"over (?:the |each )?(?:[\w-]+ )?(?:table|suite|page)'s {COUNT}\b"),
    re.compile(rf"over the {COUNT}(?= tests| comparisons|[;:,.)\]]|$)", re.M),
    re.compile(rf"family of {COUNT}\b"),
    re.compile(rf"\({COUNT} tests\)"),
    re.compile(rf"\b(?:suite|table)'s {COUNT} tests"),
]


def printed_in_markdown(text: str) -> Printed:
    text = text.replace("−", "-")
    text = re.sub(rf"{NUM}\s*→\s*", "", text)  # old → new: the new value only
    text = re.sub(r"\bfrom \d+ to (\d+)", r"\1", text)
    p = [_number(v) for group in PAGE_P.findall(text) for v in re.findall(NUM, group)]
    p += [_number(v) for v in PAGE_P_OVER.findall(text)]
    families = {_count(m) for pattern in PAGE_FAMILY for m in pattern.findall(text)}
    for header, body in _markdown_tables(text):
        for column, name in enumerate(header):
            holm_p = "holm" in name.lower() and re.search(r"\bp\b", name)
            family = name.lower() == "family"
            for cells in body:
                if column >= len(cells):
                    continue
                cell = re.sub(r"\[[^\]]*\]", "", cells[column])
                if holm_p:
                    p += [_number(v) for v in re.findall(NUM, cell)]
                if family:
                    families |= {int(v) for v in re.findall(r"\d+", cell)}
    return Printed(p, families)


def printed_in_csv(path: pathlib.Path) -> Printed:
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    if rows and "holm_p" in rows[0]:
        p = [float(r["holm_p"]) for r in rows if r["holm_p"]]
        # "needs the runs" rows count in the family as p = 1; "no data" rows are not tests.
        return Printed(p, {sum(r["holm_verdict"] != "no data" for r in rows)})
    return Printed([], {len(rows)})


def printed_on(page: pathlib.Path) -> Printed:
    """What a results page prints, with the claims tables it links to under docs/assets/."""
    text = page.read_text()
    printed = printed_in_markdown(text)
    assets = set()
    for target in LINK.findall(text):
        path = (page.parent / target).resolve()
        if ASSETS.resolve() in path.parents and path.name in ("claims.md", "claims.csv"):
            assets |= {path, path.with_name("claims.csv")}
    for path in sorted(assets):
        if not path.exists():
            continue
        more = printed_in_csv(path) if path.suffix == ".csv" else printed_in_markdown(path.read_text())
        printed.p += more.p
        printed.families |= more.families
    return printed


# --- the check ----------------------------------------------------------------------------------


def check(
    rows: list[Row],
    base: pathlib.Path,
    skipped: dict[tuple[str, str], str],
    rejudged: dict[str, str],
) -> list[str]:
    """Every figure of every row not skipped that its linked pages do not print, as a message."""
    problems = []
    cache: dict[pathlib.Path, Printed] = {}
    for row in rows:
        if any(row.source == source and row.label.startswith(start) for source, start in skipped):
            continue
        for cell in clauses(row.text):
            links = [linked_pages(c, base, rejudged) for c in cell]
            for i, clause in enumerate(cell):
                pages = next((p for p in links[i:] if p), None) or next(
                    (p for p in reversed(links[:i]) if p), []
                )
                for figure in row_figures(clause):
                    where = f"{row.source}, row {row.label[:50]!r}: {figure.kind} {figure.value}"
                    if not pages:
                        problems.append(f"{where}: no results page linked near it")
                        continue
                    printed = [cache.setdefault(p, printed_on(p)) for p in pages]
                    names = ", ".join(p.name for p in pages)
                    if figure.kind == "p":
                        found = any(matches_at_precision(figure.value, v) for pr in printed for v in pr.p)
                        if not found:
                            problems.append(f"{where}: no Holm p of that value on {names}")
                    elif not any(int(figure.value) in pr.families for pr in printed):
                        problems.append(f"{where}: no Holm family of that size on {names}")
    return problems


def summary_rows() -> tuple[list[Row], list[Row], list[Row]]:
    """README's results rows, the index's per-figure rows and "Beyond the paper", its pages."""
    readme = (ROOT / "README.md").read_text()
    index = (RESULTS / "index.md").read_text()
    readme_rows = table_rows(readme, "## What the results show", "README.md")
    index_rows = table_rows(index, "## The paper's results", "docs/results/index.md") + bullet_rows(
        index, "## Beyond the paper", "docs/results/index.md"
    )
    page_rows = bullet_rows(index, "## Pages", "docs/results/index.md")
    return readme_rows, index_rows, page_rows


# --- the tests ----------------------------------------------------------------------------------


def test_the_readme_and_index_figures_are_the_linked_pages():
    readme_rows, index_rows, page_rows = summary_rows()
    assert len(readme_rows) >= 8 and len(index_rows) >= 15 and len(page_rows) >= 30
    problems = (
        check(readme_rows, ROOT, SKIPPED, REJUDGED)
        + check(index_rows, RESULTS, SKIPPED, REJUDGED)
        + check(page_rows, RESULTS, SKIPPED, {})
    )
    assert not problems, "\n".join(problems)


def test_the_rows_state_figures_to_check():
    """The check reaches the figures: the rows hold dozens of them, each reached by a link."""
    rows = [row for rows in summary_rows() for row in rows]
    figures = [f for row in rows for cell in clauses(row.text) for c in cell for f in row_figures(c)]
    assert sum(f.kind == "p" for f in figures) >= 10
    assert sum(f.kind == "family" for f in figures) >= 5


def test_precision():
    assert matches_at_precision("5e-7", 5.06e-07)
    assert matches_at_precision("5e-7", 5.1e-7)
    assert not matches_at_precision("5e-7", 5.6e-7)
    assert matches_at_precision("0.008", 0.0077)
    assert not matches_at_precision("0.008", 0.0074)
    assert matches_at_precision("0.30", 0.303)
    assert not matches_at_precision("0.30", 0.48)
    assert matches_at_precision("1.2e-5", 1.2228e-5)
    assert not matches_at_precision("1.2e-5", 1.3e-5)
    assert matches_at_precision("0.0027", 0.00273)
    assert matches_at_precision("1", 1.0)


PAGE = """# a page

The verdicts, Holm over the table's 5 tests:

| claim | verdict | Holm p |
|---|---|---:|
| a | contradicted | 5.1e-7 |
| b | holds | 0.0077 |

Re-judged, the family grows from 5 to 7 tests (Holm p 0.30 → 0.48).
"""

README = """# litl

## What the results show

| result | what |
|---|---|
| one | walks (Holm p 5e-7 and 0.008 over the table's 5); moves (Holm p 0.48) ([page](docs/results/x.md)) |
| two | other (Holm over 5 tests) [page](docs/results/x.md) |
"""


def _synthetic(tmp_path: pathlib.Path, readme: str, page: str) -> list[str]:
    """The check on a README and one page written under tmp_path, as if they were the real ones."""
    results = tmp_path / "docs" / "results"
    results.mkdir(parents=True, exist_ok=True)
    (results / "x.md").write_text(page)
    module = globals()
    saved = module["RESULTS"], module["ASSETS"]
    module["RESULTS"], module["ASSETS"] = results, tmp_path / "docs" / "assets"
    try:
        rows = table_rows(readme, "## What the results show", "README.md")
        return check(rows, tmp_path, {}, {})
    finally:
        module["RESULTS"], module["ASSETS"] = saved


def test_the_check_passes_a_summary_that_agrees(tmp_path):
    assert _synthetic(tmp_path, README, PAGE) == []


def test_the_check_fails_when_one_number_in_a_row_changes(tmp_path):
    for old, new in [("5e-7", "6e-7"), ("0.008", "0.009"), ("table's 5", "table's 8"), ("over 5", "over 7")]:
        problems = _synthetic(tmp_path, README.replace(old, new, 1), PAGE)
        assert len(problems) == 1, (old, problems)
        assert new.split()[-1] in problems[0], problems
    # A re-judged value: the page's old value before "→" no longer counts, nor the old family.
    problems = _synthetic(tmp_path, README.replace("0.48", "0.30"), PAGE)
    assert len(problems) == 1 and "0.30" in problems[0], problems
    problems = _synthetic(tmp_path, README, PAGE.replace("5 tests:", "8 tests:"))
    assert len(problems) == 2 and all("family 5" in p for p in problems), problems


def test_a_figure_without_a_link_is_an_error(tmp_path):
    unlinked = README.replace(" [page](docs/results/x.md)", "")
    problems = _synthetic(tmp_path, unlinked, PAGE)
    assert len(problems) == 1 and "no results page linked" in problems[0], problems


def test_the_check_fails_on_a_copy_of_a_real_row_with_one_number_changed():
    readme_rows, index_rows, _ = summary_rows()
    for rows, base, old, new, named in [
        (readme_rows, ROOT, "Holm p 5e-7", "Holm p 9e-7", "p 9e-7"),
        (readme_rows, ROOT, "Holm over 28 tests", "Holm over 20 tests", "family 20"),
        (index_rows, RESULTS, "Holm p 0.003;", "Holm p 0.005;", "p 0.005"),
        (index_rows, RESULTS, "Holm over 3", "Holm over 4", "family 4"),
    ]:
        changed = [dataclasses.replace(row, text=row.text.replace(old, new)) for row in rows]
        assert changed != rows, old
        problems = check(changed, base, SKIPPED, REJUDGED)
        assert len(problems) == 1 and named in problems[0], (old, problems)
