"""The paper's claims, each measured and judged: one command runs them all.

    python -m litl.claims                      # everything, 10 seeds at demo resolution (hours)
    python -m litl.claims --panels fig4a --methods paper
    python -m litl.claims --scale smoke        # the whole suite shrunk to seconds per run
    python -m litl.claims --report-only        # judge what has finished so far
    python -m litl.claims --scale paper --slice-seeds 1 --jobs 2 --slice-threads one   # in seed slices

Runs go to `OUT/runs/<method>/<panel>/<variant>` (a second call resumes them, refusing a cell
that another commit of litl or another material started: `litl.claims.origins`); `OUT/claims.md`
and `claims.csv` hold one row per claim and method: means with 90% intervals, a two-sided test's
p-value and the verdict after a Holm-Bonferroni correction over the table's tests (the primary
one) beside the unadjusted verdict (`litl.claims.rules`), the smallest difference the seeds could
have detected, which litl and material made the cells, and each verdict again at 60% of the
iterations with whether its curves were still falling at the end (`litl.claims.cuts`);
A cell may run in seed slices (`--slice-seeds K`: `litl.claims.slices`, each slice a run of
its own, launched as the jobs of a Hydra multirun by `litl.claims.launch`) and is judged as
the union of its finished slices. `table1.md` the paper's Table 1 from the biped's runs, and
`fig4a.png` ... `fig4d.png` the panels with 90% bands. `--rejudge CLAIMS_CSV` judges a
published claims.csv again by the current rules.
"""

from litl.claims.cli import main
from litl.claims.suite import PANELS, SCALES, Cell, ClaimsError, Panel, cells, run_suite
from litl.claims.verdicts import CLAIMS, Claim, Verdict, judge, welch_p_lower

__all__ = [
    "CLAIMS",
    "PANELS",
    "SCALES",
    "Cell",
    "Claim",
    "ClaimsError",
    "Panel",
    "Verdict",
    "cells",
    "judge",
    "main",
    "run_suite",
    "welch_p_lower",
]
