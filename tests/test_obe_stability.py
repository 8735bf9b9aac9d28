"""The standard-vs-factorized OBE stability table (:mod:`boundid.studies.obe_stability`) on a tiny
study: the 3-parameter pendulum toy, a recording made from a known motion, one OBE in the
standard form (the table adds the factorized one)."""

import numpy as np
import pytest

from boundid.experiments.recording import Recording
from boundid.studies.config import load_study
from boundid.studies.data import StudyData
from boundid.studies.estimation import run_estimator
from boundid.studies.obe_stability import Condition, full_rate_rows, standard_form_stability
from boundid.studies.registry import make_robot
from boundid.studies.regressions import build_regressions

STUDY = """
regressions = ["inverse_dynamic"]
[study]
name = "toy_stability"
title = "t"
seed = 3
[robot]
model = "linear_toy"
[experiment]
source = "simulate"
duration_s = 4.0
sample_period_s = 0.005
[preprocessing]
lowpass_cutoff_hz = 10.0
decimation = 2
[prior]
center = "model"
relative_range = 0.5
absolute_range = 1.0
[[estimators]]
method = "obe"
label = "OBE-standard"
regressions = ["inverse_dynamic"]
form = "standard"
e_max = 0.2
"""

COLUMNS = {"condition", "form", "n_rows", "broke", "failure", "detail", "kind", "n_breakdowns", "error_bound",
           "shrink", "truth_ratio", "truth_in_set", "center_diff", "shape_diff", "time_s", "rows", "prior_factor",
           "repeat"}


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """(cfg, model, data, regression): two sines of the pendulum, torques by its model + uniform
    noise of 0.01 N m (e_max = 0.2 N m also covers the differentiation error of the rows)."""
    path = tmp_path_factory.mktemp("study") / "toy_stability.toml"
    path.write_text(STUDY)
    cfg = load_study(path)
    model = make_robot(cfg.robot, cfg.robot_options)
    t = np.arange(0.0, cfg.experiment.duration_s, cfg.experiment.sample_period_s)
    w, a = 2 * np.pi * np.array([0.5, 1.3]), np.array([0.8, 0.3])
    q = (np.sin(np.outer(t, w)) @ a)[:, None]
    qd = (np.cos(np.outer(t, w)) @ (a * w))[:, None]
    qdd = (-np.sin(np.outer(t, w)) @ (a * w * w))[:, None]
    tau = model.regressor(q, qd, qdd) @ model.theta_true + np.random.default_rng(0).uniform(-0.01, 0.01, q.shape)
    data = StudyData(recording=Recording(t=t, q=q, tau=tau))
    reg = build_regressions(model, data.recording, cfg.preprocessing, cfg.regressions)["inverse_dynamic"]
    return cfg, model, data, reg


def test_wide_prior_breaks_the_standard_form_only(toy):
    """Reference: [H4Paper] section III.A, the standard form "may become non definite positive";
    a prior 1e15 times the box met by these rows (each step may shrink the ellipsoid by up to 1e16
    in rho) breaks it; the factorized form keeps a guaranteed set holding the truth."""
    cfg, model, data, reg = toy
    conditions = (Condition(), Condition(prior_factor=1e15), Condition("full_rate_filtered"),
                  Condition("full_rate_unfiltered"), Condition(repeat=3))
    table = standard_form_stability(cfg, model, data, reg, conditions)
    frame = table.frame()
    assert set(frame.columns) == COLUMNS
    assert len(frame) == 2 * len(conditions) and list(frame.form[:2]) == ["standard", "factorized"]
    assert list(frame.n_rows[::2]) == [reg.n_rows, reg.n_rows, 2 * reg.n_rows, 2 * reg.n_rows, 3 * reg.n_rows]

    own = {r.form: r for r in table.rows if r.spec == Condition()}
    for form, r in own.items():  # the study's own setting: both fine, and the rows the runner would fit
        assert not r.broke and r.kind == "guaranteed" and r.truth_in_set and r.truth_ratio <= 1
        assert r.center_diff < 1e-9 and r.shape_diff < 1e-9 and r.time_s > 0
        ec = cfg.estimators[0] if form == "standard" else None
        if ec is not None:
            est = run_estimator(ec, reg, model, cfg.prior)
            assert est.n_updates > 0 and r.error_bound == est.error_bound

    wide = {r.form: r for r in table.rows if r.spec.prior_factor == 1e15}
    assert wide["standard"].broke and wide["standard"].failure == "lost positive definiteness"
    assert wide["standard"].n_breakdowns > 0 and "SolverError" in wide["standard"].detail
    assert np.isnan(wide["standard"].center_diff) and np.isnan(wide["standard"].shrink)
    assert not wide["factorized"].broke and wide["factorized"].kind == "guaranteed"
    assert wide["factorized"].truth_in_set and wide["factorized"].shrink > 1e15

    assert table.statement.startswith("The standard form does not break down in the study's own setting")
    assert "prior x 1e+15 (lost positive definiteness)" in table.statement
    assert "1 of 5 conditions" in table.statement and "factorized form broke down under none" in table.statement
    assert table.time_s > 0 and not table.skipped
    assert "lost positive definiteness" in table.text()


def test_full_rate_rows_contain_the_study_rows(toy):
    """Every decimation-th sample of the parallel-filtered full-rate rows is a row of the study
    (the same filter, not decimated), so that condition only adds the samples in between."""
    cfg, model, data, reg = toy
    filtered, unfiltered = full_rate_rows(model, data, cfg)
    d = cfg.preprocessing.decimation
    on_grid = np.isin(np.round(filtered.t / data.recording.h).astype(int) % d, 0)
    np.testing.assert_allclose(filtered.W[on_grid], reg.W, rtol=1e-9, atol=1e-9 * np.abs(reg.W).max())
    np.testing.assert_allclose(filtered.y[on_grid], reg.y, rtol=1e-9, atol=1e-9 * np.abs(reg.y).max())
    assert unfiltered.W.shape == filtered.W.shape
    assert not np.allclose(unfiltered.W, filtered.W)  # no parallel filter there
