"""A study end to end, on short data: the runner, the report page and the command line.

Independent references: the true parameters of the simulation (every guaranteed set must contain
them when the data respect the bound), the exact LP bounds (every guaranteed set must contain the
LP-bound vertices), and stdlib ``html.parser`` for the page.
"""

from __future__ import annotations

import base64
import io
import json
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from boundid.cli import main
from boundid.estimators import Estimate
from boundid.report.study_page import write_study_report
from boundid.sets import Ellipsoid
from boundid.studies.runner import tidy_table
from tiny_study import measured_twin, run_study_text, tiny_study

SHORT = tiny_study("dd_short", 7, ("filtered_dynamic", "supplied_energy", "filtered_power", "inverse_dynamic"),
                   extra="\n[preprocessing]\nlowpass_cutoff_hz = 10.0\n") + """
[[estimators]]
method = "rls"
regressions = ["filtered_dynamic", "supplied_energy", "filtered_power"]

[[estimators]]
method = "wls"
regressions = ["inverse_dynamic", "filtered_dynamic"]

[[estimators]]
method = "obe"
label = "OBE-factorized"
form = "factorized"
regressions = ["filtered_dynamic"]
e_max = 6.0

[exact]
regression = "filtered_dynamic"
e_max = 6.0
sdp = ["inner"]
projections = [["th1", "th2"]]
"""


@pytest.fixture(scope="module")
def short_study(tmp_path_factory):
    return run_study_text(tmp_path_factory.mktemp("study"), "dd_short", SHORT)


def test_runner_tidy_table_and_guarantee(short_study):
    """Every estimator x regression x parameter is a row; the guaranteed set holds the truth and
    the exact LP-bound vertices whenever the data respect the bound at the truth."""
    cfg, r = short_study
    p = r.model.p
    assert len(r.table) == p * (len(r.estimates) + 1)  # + the LP exact rows
    assert set(r.table["kind"]) == {"statistical", "guaranteed", "exact"}
    ex = r.exact
    assert ex.consistent and ex.truth_violations == 0
    obe = r.estimates[("OBE-factorized", "filtered_dynamic")]
    assert obe.contains(r.model.theta_true)
    cert = ex.certificates["OBE-factorized"]
    assert cert.contains_polytope and np.all(cert.width_ratio >= 1 - 1e-9)
    lp = r.table[r.table.estimator == "LP exact"]
    assert np.all(lp.lo.to_numpy() <= r.model.theta_true + 1e-9)
    assert np.all(lp.hi.to_numpy() >= r.model.theta_true - 1e-9)


def test_tidy_table_tells_truth_in_set_from_truth_in_intervals(short_study):
    """Constructed case, checked by hand: the unit ball about theta_true - 0.7 (1, ..., 1) holds
    every coordinate of theta_true in its interval [c_j - 1, c_j + 1] (0.7 < 1) but not theta_true
    itself (squared distance 9 x 0.49 = 4.41 > 1): truth_in_all_intervals True, truth_in_set False.
    The ball about the truth has both; the ball 1.5 away along th1 neither; a point estimate has
    no set (NA). Measured data have no known truth: NA throughout. The exact polytope of the run,
    whose data respect the bound, holds the truth in both senses."""
    cfg, r = short_study
    th = r.model.theta_true

    def ball(center):
        E = Ellipsoid.ball(center, 1.0)
        return Estimate("ball", np.asarray(center, float), E, E.intervals(), "guaranteed")

    estimates = {("corner", "reg"): ball(th - 0.7), ("centred", "reg"): ball(th),
                 ("far", "reg"): ball(th - 1.5 * np.eye(r.model.p)[0]),
                 ("point", "reg"): Estimate("LS", th + 5.0, None, (th + 4.0, th + 6.0), "point")}
    assert float((0.7 * np.ones(r.model.p)) @ (0.7 * np.ones(r.model.p))) > 1.0
    t = tidy_table(cfg, r.model, estimates, None).groupby("estimator", sort=False)[
        ["truth_in_set", "truth_in_all_intervals"]].first()
    assert t.loc["corner"].tolist() == [False, True]
    assert t.loc["centred"].tolist() == [True, True]
    assert t.loc["far"].tolist() == [False, False]
    assert t.loc["point", "truth_in_set"] is pd.NA and not t.loc["point", "truth_in_all_intervals"]
    measured = replace(cfg, experiment=replace(cfg.experiment, source="measured"))
    assert tidy_table(measured, r.model, estimates, None)[["truth_in_set", "truth_in_all_intervals"]].isna().all().all()
    lp = r.table[r.table.estimator == "LP exact"]
    assert lp["truth_in_set"].all() and lp["truth_in_all_intervals"].all()
    assert r.table["truth_in_set"].dtype == "boolean"


class _PageReader(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images, self.tables, self.urls = [], 0, []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a.get("src", ""))
        if tag == "table":
            self.tables += 1
        for key in ("src", "href"):
            if key in a and a[key] and a[key].split(":")[0] in ("http", "https"):
                self.urls.append(a[key])


def test_report_page_is_self_contained(short_study, tmp_path):
    """The page parses, every image decodes as a PNG, no external URL, under 3 MB; files beside it."""
    cfg, r = short_study
    page = write_study_report(r, tmp_path / cfg.name)
    html = page.read_text()
    reader = _PageReader()
    reader.feed(html)
    assert reader.images and reader.tables >= 4 and not reader.urls
    for src in reader.images:
        assert src.startswith("data:image/png;base64,")
        Image.open(io.BytesIO(base64.b64decode(src.split(",", 1)[1]))).verify()
    assert page.stat().st_size < 3_000_000
    for name in ("tab-table-ii", "tab-deviation", "fig-convergence", "fig-resimulation-positions", "fig-width-ratios"):
        assert name in html
    assert (page.parent / "results.csv").is_file() and (page.parent / "summary.md").is_file()
    assert list((page.parent / "tables").glob("*.tex")) and list((page.parent / "figures").glob("*.svg"))


def test_study_from_measured_csv(short_study, tmp_path):
    """A study on a recording written by the simulator gives the same estimates as the simulation."""
    cfg, r = short_study
    _, r2 = run_study_text(tmp_path, "measured", measured_twin(SHORT, r, tmp_path))
    for key, est in r.estimates.items():
        np.testing.assert_allclose(r2.estimates[key].center, est.center, rtol=1e-9, atol=1e-12)


def test_cli_run_and_errors(tmp_path, capsys):
    """`boundid run` writes the page; a bad study file exits 2 with the key named."""
    bad = tmp_path / "bad.toml"
    bad.write_text(SHORT.replace('model = "direct_drive"', 'model = "scara"'))
    assert main(["run", str(bad), "--out", str(tmp_path), "--quiet"]) == 2
    assert "robot.model" in capsys.readouterr().err


def test_cli_certify(tmp_path, capsys):
    """`boundid certify`: a ball that contains the box [-1, 1]^2 contains the polytope (exit 0);
    a tiny one does not (exit 3). Reference: the polytope is the box itself (two strips each)."""
    import pandas as pd

    W = np.array([[1.0, 0.0], [0.0, 1.0]])
    pd.DataFrame({"w1": W[:, 0], "w2": W[:, 1], "y": [0.0, 0.0], "e_max": [1.0, 1.0]}).to_csv(
        tmp_path / "reg.csv", index=False)
    (tmp_path / "big.json").write_text(json.dumps({"center": [0, 0], "shape": [[2.0, 0], [0, 2.0]]}))
    (tmp_path / "small.json").write_text(json.dumps({"center": [0, 0], "shape": [[0.5, 0], [0, 0.5]]}))
    args = ["certify", "--regression", str(tmp_path / "reg.csv"), "--no-sdp", "--json", "--ellipsoid"]
    assert main([*args, str(tmp_path / "big.json")]) == 0
    assert json.loads(capsys.readouterr().out)["contains_polytope"] is True
    assert main([*args, str(tmp_path / "small.json")]) == 3
    assert json.loads(capsys.readouterr().out)["vertices_outside"] == 4
    assert main([*args, str(Path(tmp_path / "missing.json"))]) == 2
