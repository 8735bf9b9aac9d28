"""The campaign page: findings and one small table first, failures grouped by message, details folded.

Reference: a tiny real campaign (3 scenarios x 2 replicates of a 2 s direct-drive study, in this
process; in the third, Gaussian noise of 4 N m breaks the 6 N m bound at the truth) whose replicate
table is counted here with pandas/numpy: the share of replicates whose set holds the whole true
vector, the replicates where the bound broke, failed replicates and median width over the exact LP
width per estimator and scenario, and the failed runs per message; variants of that table (a set
that misses the truth, exact sets found empty) for what the run does not show; the page is read
back with Python's html.parser.
"""

from __future__ import annotations

import re
from dataclasses import replace
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest

from boundid.experiments.measurement import TorqueNoise
from boundid.report import campaign_page as campaign_page_module
from boundid.report.campaign_page import (
    campaign_page,
    coverage_table,
    failure_groups,
    findings,
    overview,
    scenario_bounds,
    write_campaign_page,
)
from boundid.studies.campaign import run_campaign, summarize
from boundid.studies.config import load_study
from boundid.studies.scenarios import Scenario
from tiny_study import tiny_study

STUDY = tiny_study("dd_page", 3) + """
[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "obe"
label = "OBE-factorized"
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
"""

SCENARIOS = (Scenario("bounded", "uniform noise, 0.5 N m", torque_noise=TorqueNoise("uniform", 0.5)),
             Scenario("gauss", "Gaussian noise, 1 N m", torque_noise=TorqueNoise("gaussian", 1.0)),
             Scenario("gauss_high", "Gaussian noise, 4 N m: the 6 N m bound breaks",
                      torque_noise=TorqueNoise("gaussian", 4.0)))


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    root = tmp_path_factory.mktemp("camp")
    (root / "dd_page.toml").write_text(STUDY)
    cfg = load_study(root / "dd_page.toml")
    return run_campaign(cfg, 2, SCENARIOS, root / "reports" / "dd_page" / "campaign", workers=0)


class _Page(HTMLParser):
    """The page's tags in order, the text inside <details>, and the first table's cells."""

    def __init__(self):
        super().__init__()
        self.tags, self.folded, self.cells, self._details, self._tables, self._row = [], [], [], 0, 0, None

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        self._details += tag == "details"
        self._tables += tag == "table"
        if self._tables == 1 and tag == "tr":
            self._row = []
            self.cells.append(self._row)

    def handle_endtag(self, tag):
        self._details -= tag == "details"

    def handle_data(self, data):
        if self._details:
            self.folded.append(data)
        if self._tables == 1 and self._row is not None and data.strip():
            self._row.append(data.strip())


def _contains(g: pd.DataFrame) -> float:
    """% of the completed replicates of rows ``g`` whose set holds the whole true vector."""
    per = g[g.kind != "failed"].drop_duplicates("replicate")["truth_in_set"].astype(bool)
    return 100.0 * per.mean()


def test_overview_cells_are_the_counts_of_the_replicates(campaign):
    t = campaign.table
    ov = overview(summarize(t), scenario_bounds(t))
    assert list(ov.columns) == ["bounded", "gauss", "gauss_high"]
    assert sorted(ov.index) == ["LP exact", "OBE-factorized", "OBE-standard", "WLS"]
    for est in ov.index:
        for sc in ov.columns:
            cell = ov.loc[est, sc]
            assert "–" not in cell and cell.strip() != "-"
            g = t[(t.scenario == sc) & (t.estimator == est)]
            reps = t[t.scenario == sc].replicate.nunique()
            failed = g.loc[g.kind == "failed", "replicate"].nunique()
            if failed == reps:
                assert cell == f"failed in every replicate ({failed} of {reps})"
                continue
            cov, fail, width = cell.split(" · ")
            assert cov.split(" (")[0] == f"{_contains(g):.3g} %"
            assert fail == f"{100.0 * failed / reps:.3g} %"
            ok = g[g.kind != "failed"].drop_duplicates("replicate")
            ratio = ok.truth_error_ratio if est == "LP exact" else ok.bound_ratio
            done = reps - failed  # LP exact: an empty feasible set (no rows) is a completed replicate
            broken = done - int((ratio <= 1.0).sum())
            if ok.kind.iloc[0] in ("guaranteed", "exact"):
                assert (f"bound broken in {broken} of {done}" in cov) == (broken > 0)
            else:
                assert "bound" not in cov
            if est == "LP exact":
                assert width == "1"
            if est == "OBE-factorized":
                assert float(width) >= 1.0
                if broken == 0:
                    assert cov == "100 %"


def test_failures_grouped_by_message_with_counts(campaign):
    t = campaign.table
    failed = t[t.kind == "failed"].drop_duplicates(["scenario", "replicate", "estimator", "regression"])
    assert len(failed) >= 1  # the standard form breaks down on these regressors
    groups = failure_groups(t)
    assert groups["runs"].sum() == len(failed)
    for message, g in groups.iterrows():  # the group's runs: the failed runs whose message fits its pattern
        pattern = re.compile(re.escape(message).replace("\\#", "#").replace("#", r"[-+]?[\d.eE+-]+"))
        assert g["runs"] == sum(bool(pattern.fullmatch(m)) for m in failed.failure.astype(str))
    assert set(", ".join(groups["estimators"]).split(", ")) == set(failed.estimator + " / " + failed.regression)


def test_page_opens_with_findings_and_one_table_details_folded(campaign):
    page = write_campaign_page(replace(campaign))
    text = page.read_text()
    p = _Page()
    p.feed(text)
    tags = [t for t, _ in p.tags]
    first_table = tags.index("table")
    assert text.index('class="findings') < text.index("<table")
    assert "details" not in tags[:first_table]
    rows = p.cells
    assert rows[0] == ["estimator", "bounded", "gauss", "gauss_high"] and len(rows) == 5
    folded = " ".join(p.folded)
    for heading in ("Coverage of the truth", "Width, bias and RMSE", "Failed runs"):  # visible heading, folded body
        assert f'<h2>{heading}</h2>\n<details class="fold">' in text
    for caption in ("Coverage of the truth per scenario", "Width over the exact width", "Failed estimator runs"):
        assert caption in folded
    groups = failure_groups(campaign.table)
    for g in groups.itertuples():
        assert f"{g.runs} run{'s' * (g.runs > 1)} ({g.estimators}; scenarios {g.scenarios})" in text
    assert "the guaranteed sets (OBE-factorized) contain the truth in every replicate" in text
    assert "No estimator failed" not in text
    assert (page.parent / "tables" / "overview.csv").is_file()
    assert campaign_page(campaign).title == "Monte Carlo campaign: Direct-drive arm, 2 s"
    assert pd.read_csv(page.parent / "tables" / "overview.csv", index_col=0).shape == (4, 3)


def _broken(t: pd.DataFrame, scenario: str) -> tuple[int, int]:
    """(replicates where the bound is broken at the truth, replicates) of a scenario."""
    reps = t[t.scenario == scenario].drop_duplicates("replicate")
    return int((reps.truth_error_ratio > 1.0).sum()), len(reps)


def test_headline_names_the_scenario_that_breaks_the_guarantee_with_its_rates(campaign):
    """A scenario whose bound breaks at the truth opens the findings, with the rate and the share of
    replicates whose guaranteed sets contain the truth; the box asks for attention."""
    t = campaign.table
    k, n = _broken(t, "gauss_high")
    assert k >= 1, "the 4 N m scenario must break the 6 N m bound"
    assert _broken(t, "bounded")[0] == _broken(t, "gauss")[0] == 0
    sentences, attention = findings(summarize(t), t)
    obe = _contains(t[(t.scenario == "gauss_high") & (t.estimator == "OBE-factorized")])
    assert attention
    assert sentences[0].startswith(f"gauss_high: the bound e_max = 6 N m is broken at the truth in {100 * k / n:.3g} % "
                                   f"of replicates ({k} of {n})")
    assert f"the guaranteed sets contain the truth in {obe:.3g} % of replicates" in sentences[0]
    # a variant where the guaranteed set misses the truth there: the headline says so, with its rate
    missed = t.assign(truth_in_set=t.truth_in_set.mask((t.scenario == "gauss_high") & (t.estimator == "OBE-factorized")
                                                       & (t.replicate == 0), False))
    first = findings(summarize(missed), missed)[0][0]
    assert f"the guaranteed sets contain the truth in {100 * (obe / 100 * n - 1) / n:.3g} % of replicates" in first
    page = write_campaign_page(replace(campaign)).read_text()
    box = page[page.index('class="findings'):page.index("<table")]
    assert "attention" in box.split(">")[0] and "gauss_high: the bound e_max = 6 N m is broken at the truth" in box
    # a guaranteed set missing the truth where its bound held is a bug, and the findings say it
    bug = t.assign(truth_in_set=t.truth_in_set.mask((t.scenario == "bounded") & (t.estimator == "OBE-factorized"),
                                                    False))
    assert any(s.startswith("A guaranteed set missed the truth although the errors respected its bound (a bug): "
                            "OBE-factorized in bounded, contains it in 0 %") for s in findings(summarize(bug), bug)[0])


def test_one_coverage_in_the_overview_the_table_and_the_figure(campaign, monkeypatch):
    """The page states its coverage once, and the overview, the coverage table and the coverage
    figure all show that number (the figure's bars read from the same summary column)."""
    drawn = {}
    bars = campaign_page_module._grouped_bars

    def spy(summary, column, ylabel, **kw):
        drawn[ylabel] = summary.set_index(["scenario", "estimator"])[column]
        return bars(summary, column, ylabel, **kw)

    monkeypatch.setattr(campaign_page_module, "_grouped_bars", spy)
    t = campaign.table
    page = write_campaign_page(replace(campaign))
    text = page.read_text()
    assert text.count("Coverage, the one definition used on this whole page") == 1
    assert text.count("whole true parameter vector") == 1
    ov = pd.read_csv(page.parent / "tables" / "overview.csv", index_col=0)
    cov = pd.read_csv(page.parent / "tables" / "coverage.csv", index_col=0)
    figure = drawn["coverage [%]"]
    for (sc, est), v in figure.items():
        g = t[(t.scenario == sc) & (t.estimator == est)]
        if (g.kind == "failed").all():
            assert np.isnan(v) and cov.loc[f"{sc} / {est} / filtered_dynamic", "coverage [%]"] == \
                "failed in every replicate"
            continue
        assert v == pytest.approx(_contains(g))
        assert cov.loc[f"{sc} / {est} / filtered_dynamic", "coverage [%]"] == f"{v:.4g}"
        assert ov.loc[est, sc].startswith(f"{v:.3g} %")


def test_no_dash_where_a_number_exists_and_words_where_none_can(campaign):
    """Every cell of the overview and of the coverage table is a number or says in words why there
    is none; a scenario whose exact set is empty in every replicate (the data contradict the bound)
    gets an LP exact cell saying so, and the widths say there is no exact width."""
    t = campaign.table
    empty = t[~((t.scenario == "gauss_high") & (t.estimator == "LP exact"))]  # the exact set empty: no LP rows
    summary = summarize(empty)
    ov = overview(summary, scenario_bounds(empty))
    n = t[t.scenario == "gauss_high"].replicate.nunique()
    assert ov.loc["LP exact", "gauss_high"].startswith(f"0 % (bound broken in {n} of {n}; set empty in {n} of {n})")
    assert ov.loc["LP exact", "gauss_high"].endswith("no width (set empty)")
    for est in ("OBE-factorized", "WLS"):
        assert ov.loc[est, "gauss_high"].endswith("no width (exact set empty)")
    assert "failed in every replicate" in ov.loc["OBE-standard", "gauss_high"]
    cov = coverage_table(summary, scenario_bounds(empty))
    for frame in (ov, cov):
        for cell in frame.astype(str).to_numpy().ravel():
            assert cell.strip() not in ("-", "–", "", "nan") and "–" not in cell
    text = write_campaign_page(replace(campaign, table=empty)).read_text()
    cells = re.findall(r"<td[^>]*>(.*?)</td>", text, flags=re.S)
    assert cells and not [c for c in cells if c.strip() in ("-", "–", "")]


def test_no_link_to_a_folder_the_replicate_files_have_an_index(campaign):
    """No href of the page ends in "/" or names a folder without index.html; the replicate files
    are linked from data/index.html, which lists every one of them."""
    page = write_campaign_page(replace(campaign))
    p = _Page()
    p.feed(page.read_text())
    hrefs = [a["href"] for tag, a in p.tags if tag == "a" and "href" in a]
    assert "data/index.html" in hrefs
    for href in hrefs:
        if href.startswith(("#", "http:", "https:", "data:")):
            continue
        target = page.parent / href.split("#")[0]
        assert not href.endswith("/") and not target.is_dir(), f"a link to a folder: {href}"
    index = page.parent / "data" / "index.html"
    listed = _Page()
    listed.feed(index.read_text())
    linked = {a["href"] for tag, a in listed.tags if tag == "a" and a.get("href", "").endswith(".parquet")}
    assert linked == {f.name for f in (page.parent / "data").glob("*.parquet")} and len(linked) == 3 * 2
    assert all(not h.endswith("/") for tag, a in listed.tags if tag == "a" for h in [a.get("href", "")])
