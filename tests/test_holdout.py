"""Held-out validation of a measured recording: identify on its first part, predict the rest.

Independent references: scipy.optimize.linprog for the exact band [min, max] of w^T theta over the
feasible polytope; the certified containment of the OBE ellipsoid (it contains the polytope, so its
band must contain the exact band); the bands' coverage counted here from the measured torques.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.errors import StudyError
from boundid.experiments.recording import Recording
from boundid.report.study_page import study_page
from boundid.studies.config import load_study
from boundid.studies.data import split_recording
from tiny_study import measured_twin, run_study_text, tiny_study

HEAD = tiny_study("held", 2, ("inverse_dynamic",), extra="[preprocessing]\nlowpass_cutoff_hz = 10.0\n")
TAIL = """
[[estimators]]
method = "obe"
label = "OBE"
regressions = ["inverse_dynamic"]

[[estimators]]
method = "wls"
label = "WLS"
regressions = ["inverse_dynamic"]

[exact]
regression = "inverse_dynamic"
e_max_rule = {}
"""


def test_split_recording_keeps_every_sample_once():
    t = np.arange(1000) * 0.01
    rec = Recording(t, np.c_[t, 2 * t], np.c_[-t, t])
    first, rest = split_recording(rec, 0.3)
    assert first.t.size == 700 and rest.t.size == 300 and rest.t[0] == t[700]
    np.testing.assert_array_equal(np.r_[first.q, rest.q], rec.q)
    assert split_recording(rec, 0.0) == (rec, None)


@pytest.fixture(scope="module")
def held(tmp_path_factory):
    folder = tmp_path_factory.mktemp("held")
    _, sim = run_study_text(folder, "sim", HEAD + TAIL)
    text = measured_twin(HEAD + TAIL, sim, folder)
    return run_study_text(folder, "held", text.replace("[experiment.measured]\nfile",
                                                       "[experiment.measured]\nholdout_fraction = 0.5\nfile"))


def test_the_exact_band_is_the_lp_optimum_and_inside_the_obe_band(held):
    _, r = held
    v = r.validation
    assert r.data.validation.t[0] > r.data.recording.t[-1]  # identified without the held-out samples
    bands, reg = v["torque_bands"], v["validation_regression"]
    exact, obe = bands["LP exact"], bands["OBE"]
    P = r.exact.polytope
    A, b = np.vstack([P.W, -P.W]), np.r_[P.y + P.e_max, -(P.y - P.e_max)]
    bounds = list(zip(*P.box, strict=True))
    samples, row = np.unique(reg.sample, return_inverse=True)
    for k in np.linspace(0, reg.n_rows - 1, 6).astype(int):
        w, s, j = reg.W[k], row[k], reg.joint[k]
        lo = linprog(w, A_ub=A, b_ub=b, bounds=bounds, method="highs").fun
        hi = -linprog(-w, A_ub=A, b_ub=b, bounds=bounds, method="highs").fun
        assert exact.lower[s, j] == pytest.approx(lo, abs=1e-7 * (1 + abs(lo)))
        assert exact.upper[s, j] == pytest.approx(hi, abs=1e-7 * (1 + abs(hi)))
    assert r.exact.certificates["OBE"].contains_polytope
    ok = ~np.isnan(exact.lower)
    assert np.all(obe.lower[ok] <= exact.lower[ok] + 1e-9) and np.all(exact.upper[ok] <= obe.upper[ok] + 1e-9)


def test_coverage_of_the_measured_torques_is_counted_with_the_bound(held):
    _, r = held
    v = r.validation
    m, exact = v["validation_measured"], v["torque_bands"]["LP exact"]
    e = np.unique(r.exact.e_max)
    assert e.size == 1 and np.allclose(exact.error_bound, e[0])  # one bound on every row: the default rule
    ok = ~np.isnan(m)
    outside = (m < exact.lower - e[0]) | (m > exact.upper + e[0])
    assert exact.outside_measured_fraction(m) == pytest.approx(outside[ok].mean())
    assert v["torque_bands"]["WLS"].error_bound is None
    assert np.isnan(v["torque_bands"]["WLS"].outside_measured_fraction(m))


def test_the_page_states_what_was_held_out(held):
    _, r = held
    page = study_page(r)
    text = page.to_markdown()
    assert "## Held-out validation: predicted torques" in text
    assert "the last 50 % of the recording" in page.setup["held-out torques"]
    assert "LP exact's band (mean half-width" in page.setup["held-out torques"]
    assert "N m) widened by e_max holds 100 %" in page.setup["held-out torques"]


def test_a_holdout_beyond_half_is_refused(tmp_path):
    t = np.arange(100) * 0.0025
    fake = SimpleNamespace(data=SimpleNamespace(recording=Recording(t, np.c_[t, t], np.c_[t, t])))
    path = tmp_path / "x.toml"
    path.write_text(measured_twin(HEAD + TAIL, fake, tmp_path).replace(
        "[experiment.measured]\nfile", "[experiment.measured]\nholdout_fraction = 0.6\nfile"))
    with pytest.raises(StudyError, match="holdout_fraction: must be >= 0, <= 0.5, got 0.6"):
        load_study(path)


def test_a_holdout_too_short_for_a_row_names_the_fraction_that_works(tmp_path):
    _, sim = run_study_text(tmp_path, "sim", HEAD + TAIL)
    text = measured_twin(HEAD + TAIL, sim, tmp_path).replace("[experiment.measured]\nfile",
                                                            "[experiment.measured]\nholdout_fraction = 0.2\nfile")
    path = tmp_path / "short.toml"
    path.write_text(text)
    from boundid.studies.data import acquire
    from boundid.studies.registry import make_robot

    cfg = load_study(path)
    with pytest.raises(StudyError, match="holdout_fraction = 0.2 keeps 0.397 s out, too short .* raise it to at least"):
        acquire(cfg, make_robot(cfg.robot, cfg.robot_options), np.random.default_rng(0))


def test_a_holdout_without_inverse_dynamic_rows_is_refused(tmp_path):
    t = np.arange(100) * 0.0025
    fake = SimpleNamespace(data=SimpleNamespace(recording=Recording(t, np.c_[t, t], np.c_[t, t])))
    head = tiny_study("held", 2)  # filtered_dynamic only
    tail = TAIL.replace("inverse_dynamic", "filtered_dynamic")
    path = tmp_path / "x.toml"
    path.write_text(measured_twin(head + tail, fake, tmp_path).replace(
        "[experiment.measured]\nfile", "[experiment.measured]\nholdout_fraction = 0.3\nfile"))
    with pytest.raises(StudyError, match='holdout_fraction: the held-out torques are predicted by the inverse_dynamic '
                                         'rows.* add "inverse_dynamic" to regressions'):
        load_study(path)
