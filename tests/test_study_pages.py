"""The study page's verdicts, findings, prior-box intervals, set comparison and figures.

Independent references: closed forms (a converging exponential and an undamped oscillation for the
convergence criterion, hand-counted stored numbers of an ellipsoid and a box), the prior box the
study declares (no guaranteed interval may reach outside it), a second run of the same study (same
seed, same machine: identical results.csv), and :func:`boundid.report.figure_check.figure_problems`
(every artist inside the figure, no overlapping tick labels) on every figure a study page draws.
"""

from __future__ import annotations

import re
from html import unescape

import numpy as np
import pandas as pd
import pytest

from boundid.estimators.estimate import History
from boundid.report import html as report_html
from boundid.report.figure_check import figure_problems
from boundid.report.study_page import (
    PART_MARK,
    STAGE_NAMES,
    clipped_intervals,
    numbers_stored,
    set_comparison,
    write_study_report,
)
from boundid.sets import Box, Ellipsoid
from boundid.studies.reproduction import VERDICTS, claims, drift, prior_bounds, shrank
from boundid.studies.runner import run_study
from tiny_study import measured_twin, run_study_text, tiny_study

SMALL = tiny_study("dd_small", 11, ("filtered_dynamic", "supplied_energy", "filtered_power")) + """
[[estimators]]
method = "rls"
label = "RLS"
regressions = ["filtered_dynamic", "supplied_energy", "filtered_power"]

[[estimators]]
method = "obe"
label = "OBE-factorized"
form = "factorized"
regressions = ["filtered_dynamic"]
e_max = 6.0

[[estimators]]
method = "obe"
label = "OBE-standard"
form = "standard"
regressions = ["filtered_dynamic"]
e_max = 6.0

[exact]
regression = "filtered_dynamic"
e_max = 6.0
sdp = ["inner"]
projections = [["th1", "th2"]]
"""


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    return run_study_text(tmp_path_factory.mktemp("study"), "dd_small", SMALL)


@pytest.fixture(scope="module")
def drawn(small, tmp_path_factory):
    """The page written, with the problems figure_problems finds in each figure it draws."""
    cfg, r = small
    problems: dict[str, list[str]] = {}
    original = report_html.Page.figure

    def checked(self, fig, caption, *, name=None):
        problems[name or caption] = figure_problems(fig)
        return original(self, fig, caption, name=name)

    report_html.Page.figure = checked
    try:
        page = write_study_report(r, tmp_path_factory.mktemp("out") / cfg.name)
    finally:
        report_html.Page.figure = original
    return page, problems


def test_same_seed_same_results_csv(small, tmp_path):
    """Reference: a second run of the same study file on the same machine; results.csv identical."""
    cfg, r = small
    again = run_study(cfg)
    assert again.table.to_csv(index=False) == r.table.to_csv(index=False)
    sweep, sweep2 = r.validation["obe_sweep"], again.validation["obe_sweep"]
    assert sweep.outcomes == sweep2.outcomes


def test_no_guaranteed_interval_reaches_outside_the_prior_box(small, drawn):
    """Reference: the study's prior box (+-100 about 0). Every interval column of every table on the
    page, and each set's clipped intervals, lie inside it; raw OBE intervals do reach outside."""
    cfg, r = small
    lo, hi = prior_bounds(r)
    page, _ = drawn
    pairs = 0
    for csv in (page.parent / "tables").glob("*.csv"):
        df = pd.read_csv(csv, index_col=0)
        for col in df.columns:
            if col.endswith(" lo") and col[:-3] + " hi" in df.columns and "95 %" not in col:
                pairs += 1
                assert np.all(df[col].to_numpy(float) >= lo - 1e-12), csv.name
                assert np.all(df[col[:-3] + " hi"].to_numpy(float) <= hi + 1e-12), csv.name
    assert pairs >= 2
    for e in r.estimates.values():
        if e.set_membership:
            clo, chi = clipped_intervals(e, (lo, hi))
            assert np.all(clo >= lo) and np.all(chi <= hi)
    summary, per_param = set_comparison(r)
    ex = r.exact
    assert np.all(per_param.to_numpy() <= ((hi - lo) / (ex.bounds.hi - ex.bounds.lo))[:, None] + 1e-9)
    assert np.all(per_param.loc[:, [c for c in per_param if c.startswith("OBE")]].to_numpy() >= 1 - 1e-9)
    assert set(summary["contains polytope"]) <= {"yes", "no (inner)"}


def test_shrank_says_whether_the_data_told_more_than_the_prior():
    """Hand-made intervals: an LP interval equal to the box is not shrunk, a narrower one is."""
    np.testing.assert_array_equal(shrank([-1.0, -0.5], [1.0, 1.0], [-1.0, -1.0], [1.0, 1.0]), [False, True])


def test_drift_tells_convergence_from_oscillation():
    """Closed forms on t in [0, 1]: 1 - exp(-t / 0.05) settles (drift over the last quarter
    (exp(-15) - exp(-20)) / (1 - exp(-20))); sin(2 pi t) does not (it spans 1 over the last quarter)."""
    t = np.linspace(0.0, 1.0, 1001)
    centers = np.column_stack([1.0 - np.exp(-t / 0.05), np.sin(2 * np.pi * t) + 0.0])
    d = drift(History(np.arange(t.size), centers, np.zeros(t.size)))
    assert d[0] == pytest.approx((np.exp(-15.0) - np.exp(-20.0)) / (1.0 - np.exp(-20.0)), rel=1e-6)
    assert d[1] > 1.0


def test_numbers_stored_by_family():
    """Hand count: a 3-D ellipsoid keeps 3 + 6 numbers, a 3-D box its lo and hi (6)."""
    assert numbers_stored(Ellipsoid.ball(np.zeros(3), 1.0)) == 9
    assert numbers_stored(Box(np.zeros(3), np.ones(3))) == 6


def test_page_opens_with_findings_and_verdicts(small, drawn):
    """Every verdict is one of the four and stated on the page; the findings come before the first
    section; the OBE sweep and the platform are reported."""
    cfg, r = small
    page, _ = drawn
    html = page.read_text()
    verdicts = claims(r)
    assert verdicts and {c.verdict for c in verdicts} <= set(VERDICTS)
    assert html.index("bound at the truth") < html.index("<h2>")
    assert html.index("Does it reproduce?") < html.index("Set-up")
    for c in verdicts:
        assert c.reason.split(";")[0][:30] in unescape(html)
    assert "OBE breakdown rate" in html and "numpy" in html
    sweep = r.validation["obe_sweep"]
    assert len(sweep.seeds) == 20 and set(sweep.outcomes) == {"OBE-factorized / filtered_dynamic",
                                                              "OBE-standard / filtered_dynamic"}
    assert not re.search(r">\s*(True|False)\s*<", html)


def test_every_study_figure_passes_the_artist_check(drawn):
    """figure_problems on every figure the page draws: nothing clipped, no tick labels overlapping."""
    _, problems = drawn
    assert problems and all(not p for p in problems.values()), problems


def test_measured_data_show_no_truth(small, tmp_path):
    """A measured recording (written by the simulator) gives a page with no truth column, no
    deviation from truth and no paper tables, and no paper verdicts."""
    cfg, r = small
    _, r2 = run_study_text(tmp_path, "measured", measured_twin(SMALL, r, tmp_path))
    html = write_study_report(r2, tmp_path / "measured").read_text()
    assert "Table II" not in html and "Deviation from truth" not in html and "truth in set" not in html
    assert "Does it reproduce?" not in html and "measured data have no truth" in html


def test_page_shows_where_the_time_went(small, drawn):
    """The time table lists every stage the run timed, the exact optima's parts under their total, and
    the page itself; its shares are of the whole, and the slowest stage is named."""
    cfg, r = small
    page, _ = drawn
    html = unescape(page.read_text())
    assert "Where the time went" in html
    times = pd.read_csv(page.parent / "tables" / "times.csv", index_col=0)
    names = [n.removeprefix(PART_MARK) for n in times.index]
    for key in r.timings:
        assert STAGE_NAMES[key] in names
    for key in r.exact.time_s:
        assert STAGE_NAMES[key] in names
    assert any(n.startswith("this page") for n in names)
    top = [n for n in times.index if not n.startswith(PART_MARK)]
    shares = times.loc[top, "share of the run"].str.rstrip(" %").astype(float)
    assert shares.sum() == pytest.approx(100, abs=len(top))        # rounded to whole per cent
    slowest = max(r.timings, key=r.timings.get)
    assert f"the slowest stage: {STAGE_NAMES[slowest]}" in html
