"""The claims registers: verdicts that count only what was tested, claims that hold by construction
said so, and the paper's own extra fits (the H4 paper's bound raised from 5 % to 15 %, the
direct-drive paper's supplied energy with known Coulomb coefficients)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from boundid.experiments.regression import Regression
from boundid.models.direct_drive import DirectDriveArm
from boundid.studies.paper_experiments import bound_trials, known_coulomb_fit
from boundid.studies.reproduction import _H4, TESTED, VERDICTS, Claim, summary
from tiny_study import run_study_text, tiny_study


def _claim(verdict: str) -> Claim:
    return Claim("X1", "§1", "a claim", "paper", "method", "ours", verdict, "reason")


def test_summary_counts_only_the_tested_claims():
    """Two tested claims (one reproduced, one not), one by construction, one untestable: "2 tested"."""
    found = [_claim(v) for v in ("reproduced", "not reproduced", "holds by construction", "cannot be tested")]
    assert summary(found) == ("2 paper claims tested: 1 reproduced, 1 not; 1 holds by construction, "
                              "1 cannot be tested")
    assert set(TESTED) < set(VERDICTS) and "holds by construction" not in TESTED


def _h4_context(*, violations: int, lp_lo, lp_hi, center) -> _H4:
    """A stand-in H4 run: two parameters with priors 1 and 2 in a prior box +-50 % about them, [0.5, 1.5]
    and [1, 3] (see :func:`boundid.studies.reproduction.prior_bounds`); truths 1.5 and 2.5 (50 % and 25 %
    off their priors); a guaranteed OBE with the given centre."""
    p = 2
    model = SimpleNamespace(param_names=("Imot1", "Mnac"), theta_prior=np.array([1.0, 2.0]),
                            theta_true=np.array([1.5, 2.5]), p=p)
    prior = SimpleNamespace(center="model", relative_range=0.5, absolute_range=1.0)
    cfg = SimpleNamespace(prior=prior, paper={"outlier_rate_percent_below": 0.03}, robot="h4")
    exact = SimpleNamespace(bounds=SimpleNamespace(lo=np.asarray(lp_lo, float), hi=np.asarray(lp_hi, float)),
                            truth_violations=violations, truth_error_ratio=0.5 if violations == 0 else 1.5)
    obe = SimpleNamespace(center=np.asarray(center, float), n_outliers=0, n_samples=100, guaranteed=True, p=p,
                          kind="guaranteed")
    r = SimpleNamespace(model=model, config=cfg, exact=exact, validation={}, failures=[], regressions={})
    return _H4(r, {"OBE-factorized": obe}, "OBE-factorized", obe, "factorized OBE")


def test_outliers_hold_by_construction_only_where_the_bound_holds_at_the_truth():
    """No row breaks the bound at the truth: the OBE cannot meet an outlier, so the claim cannot fail;
    with rows over the bound it is tested."""
    box = dict(lp_lo=[0.5, 1.0], lp_hi=[1.5, 3.0], center=[1.0, 2.0])
    assert _h4_context(violations=0, **box).outliers().verdict == "holds by construction"
    assert _h4_context(violations=3, **box).outliers().verdict == "reproduced"


def test_centre_claim_is_tested_only_on_the_parameters_the_data_identify():
    """Exact intervals equal to the prior box: nothing to test (by construction); Mnac narrowed 4 x
    inside the criterion's band (its prior +- 50 %, the stand-in Table I's largest deviation): any
    consistent estimate passes (by construction). Mnac's interval reaching past the band: tested, its
    centre 10 % off its prior passes, and only partly, since Imot1 is not identified; 60 % off: not
    reproduced."""
    c = _h4_context(violations=0, lp_lo=[0.5, 1.0], lp_hi=[1.5, 3.0], center=[1.2, 2.2])
    assert c.centre().verdict == "holds by construction"
    c = _h4_context(violations=0, lp_lo=[0.5, 2.0], lp_hi=[1.5, 2.5], center=[1.2, 2.2])
    assert c.centre().verdict == "holds by construction" and "lie within the criterion's band" in c.centre().reason
    claim = _h4_context(violations=0, lp_lo=[0.5, 2.4], lp_hi=[1.5, 3.2], center=[1.2, 2.2]).centre()
    assert claim.verdict == "partly" and "Mnac (10 % off the prior" in claim.reason
    assert "the data do not identify Imot1" in claim.reason
    claim = _h4_context(violations=0, lp_lo=[0.5, 3.1], lp_hi=[1.5, 3.3], center=[1.2, 3.2]).centre()
    assert claim.verdict == "not reproduced" and "60 % off the prior" in claim.reason


def test_known_coulomb_fit_recovers_the_truth_on_noise_free_rows():
    """Rows y = W theta_true exactly: RLS on y - W_c theta_c over the other columns (theta(0) = 0,
    P(0) = 1000 I, whose pull is 1e-3 / (W^T W)) returns the truth; the Coulomb entries are the
    truth's by construction."""
    model = DirectDriveArm()
    rng = np.random.default_rng(3)
    W = rng.standard_normal((4000, model.p)) * 10.0
    reg = Regression(W, W @ model.theta_true, np.full(4000, -1), np.arange(4000), np.arange(4000) * 1e-3,
                     "supplied_energy", tuple(model.param_names), "J")
    cfg = SimpleNamespace(experiment=SimpleNamespace(source="simulate"), estimators=())  # the default RLS start
    k = known_coulomb_fit(cfg, model, {"supplied_energy": reg})
    assert [model.param_names[j] for j in k.coulomb] == ["fc1", "fc2"]
    np.testing.assert_allclose(k.center, model.theta_true, rtol=1e-6)
    assert k.estimate.p == model.p - 2


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    text = tiny_study("paper_bounds", 7) + """
[[estimators]]
method = "obe"
label = "OBE-factorized"
regressions = ["filtered_dynamic"]
form = "factorized"
e_max = 6.0

[paper]
torque_range = 100.0
bound_percents = [0.2, 10.0]
"""
    cfg, r = run_study_text(tmp_path_factory.mktemp("paper_bounds"), "paper_bounds", text)
    return bound_trials(cfg, r.model, r.regressions), r


def test_bound_trials_refit_the_paper_estimator_at_each_bound(trials):
    """Uniform torque noise of 0.5 N m on the filtered dynamic rows: a 0.2 N m bound is broken by the
    truth and the factorized OBE meets outliers; 10 N m holds at the truth and meets none."""
    found, r = trials
    tight, wide = found
    assert (tight.percent, tight.e_max, wide.e_max) == (0.2, pytest.approx(0.2), pytest.approx(10.0))
    reg = r.regressions["filtered_dynamic"]
    error = np.abs(reg.y - reg.W @ r.model.theta_true)
    assert tight.truth_over == int(np.sum(error > 0.2)) > 0 and wide.truth_over == 0
    assert tight.outliers > 0 and wide.outliers == 0 and tight.rows == wide.rows == reg.n_rows
