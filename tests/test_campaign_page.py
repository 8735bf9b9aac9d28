"""The campaign page: findings and one small table first, failures grouped by message, details folded.

Reference: a tiny real campaign (2 scenarios x 2 replicates of a 2 s direct-drive study, in this
process) whose replicate table is counted here with pandas/numpy: coverage of the truth, failed
replicates and median width over the exact LP width per estimator and scenario, and the failed
runs per message; the page is read back with Python's html.parser.
"""

from __future__ import annotations

import re
from dataclasses import replace
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest

from boundid.experiments.measurement import TorqueNoise
from boundid.report.campaign_page import campaign_page, failure_groups, overview, write_campaign_page
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
             Scenario("gauss", "Gaussian noise, 1 N m", torque_noise=TorqueNoise("gaussian", 1.0)))


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


def test_overview_cells_are_the_counts_of_the_replicates(campaign):
    t = campaign.table
    ov = overview(summarize(t))
    assert list(ov.columns) == ["bounded", "gauss"]
    assert sorted(ov.index) == ["LP exact", "OBE-factorized", "OBE-standard", "WLS"]
    for est in ov.index:
        for sc in ov.columns:
            g = t[(t.scenario == sc) & (t.estimator == est)]
            ok = g[g.kind != "failed"]
            reps = g.replicate.nunique()
            failed = g.loc[g.kind == "failed", "replicate"].nunique()
            if len(ok) and ok.kind.iloc[0] == "guaranteed":
                ok = ok[ok.bound_ratio <= 1.0]  # a guarantee counts where its bound held
            covered = ((ok.lo <= ok.truth) & (ok.truth <= ok.hi)).mean() * 100 if len(ok) else np.nan
            cov, fail, width = ov.loc[est, sc].split(" · ")
            assert cov == ("–" if np.isnan(covered) else f"{covered:.3g} %")
            assert fail == f"{100.0 * failed / reps:.3g} %"
            if est == "LP exact":
                assert width == "1"
            if est == "OBE-factorized":
                assert cov == "100 %" and float(width) >= 1.0


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
    assert rows[0] == ["estimator", "bounded", "gauss"] and len(rows) == 5
    folded = " ".join(p.folded)
    for heading in ("Coverage of the truth", "Width, bias and RMSE", "Failed runs"):  # visible heading, folded body
        assert f'<h2>{heading}</h2>\n<details class="fold">' in text
    for caption in ("Coverage of the true parameters", "Width over the exact width", "Failed estimator runs"):
        assert caption in folded
    groups = failure_groups(campaign.table)
    for g in groups.itertuples():
        assert f"{g.runs} run{'s' * (g.runs > 1)} ({g.estimators}; scenarios {g.scenarios})" in text
    assert "Every guaranteed set (OBE-factorized" in text and "No estimator failed" not in text
    assert (page.parent / "tables" / "overview.csv").is_file()
    assert campaign_page(campaign).title == "Monte Carlo campaign: Direct-drive arm, 2 s"
    assert pd.read_csv(page.parent / "tables" / "overview.csv", index_col=0).shape == (4, 2)
