"""Choosing the bound: gamma* three ways, bound rules in study files, and the default rule held
against recordings from an independent simulator (MuJoCo).

Independent references: gamma* by scipy.optimize.linprog (min t s.t. -t s_k <= y_k - w_k^T theta
<= t s_k, theta in the box), and the definition itself: at the rule's bounds times 1 + 1e-6 the
feasible polytope is non-empty, at 1 - 1e-3 it is empty; the MuJoCo recordings' true parameters.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.errors import InputError, StudyError
from boundid.experiments.regression import Regression
from boundid.report.verdict import run_verdict
from boundid.sets import Polytope
from boundid.studies.bounds import DEFAULT_RULE, SCALINGS, BoundRule, bound_sweep, gamma_star, where_rows_sit
from boundid.studies.config import load_study
from tiny_study import measured_twin, run_study_text, tiny_study


def _regression(seed: int = 0, n: int = 3, rows: int = 60, p: int = 4) -> tuple[Regression, tuple]:
    """Rows of n joints whose errors differ in size by joint (uniform, half-widths 0.1, 0.5, 2)."""
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=p)
    W = rng.normal(size=(rows * n, p))
    joint = np.tile(np.arange(n), rows)
    y = W @ theta + rng.uniform(-1, 1, rows * n) * np.array([0.1, 0.5, 2.0])[joint]
    reg = Regression(W, y, joint, np.repeat(np.arange(rows), n), np.repeat(np.arange(rows) * 0.01, n),
                     "inverse_dynamic", tuple(f"p{i}" for i in range(p)))
    return reg, (np.full(p, -10.0), np.full(p, 10.0))


def _linprog_gamma(W, y, s, box) -> float:
    """min t s.t. |y_k - w_k^T theta| <= t s_k, theta in box (scipy's HiGHS)."""
    N, p = W.shape
    A = np.block([[-W, -s[:, None]], [W, -s[:, None]]])
    res = linprog(np.r_[np.zeros(p), 1.0], A_ub=A, b_ub=np.r_[-y, y],
                  bounds=[*zip(box[0], box[1], strict=True), (0, None)], method="highs")
    return float(res.fun)


def test_gamma_star_three_ways_against_linprog():
    reg, box = _regression()
    gs = gamma_star(reg, box)
    assert gs.one == pytest.approx(_linprog_gamma(reg.W, reg.y, np.ones(reg.n_rows), box), rel=1e-7)
    for j in range(3):
        rows = reg.joint == j
        assert gs.per_group[j] == pytest.approx(_linprog_gamma(reg.W[rows], reg.y[rows], np.ones(rows.sum()), box),
                                                rel=1e-7)
    s = gs.spread[reg.joint]
    assert gs.scaled == pytest.approx(_linprog_gamma(reg.W, reg.y, s, box), rel=1e-7)
    assert gs.per_joint >= 1.0 - 1e-9  # the joints' own gamma* are not jointly consistent, in general
    assert gs.spread[0] < gs.spread[1] < gs.spread[2]  # the joints' noise levels, 0.1 < 0.5 < 2 (uniform)


@pytest.mark.parametrize("scaling", SCALINGS)
def test_rule_bounds_are_the_smallest_consistent(scaling):
    """Definition: the polytope of factor x the smallest bounds is non-empty for factor 1 + 1e-6 and
    empty for 1 - 1e-3."""
    reg, box = _regression(seed=1)
    gs = gamma_star(reg, box)
    smallest = gs.smallest(scaling, reg.joint)
    assert not Polytope.from_strips(reg.W, reg.y, (1 + 1e-6) * smallest, box=box).consistency().empty
    assert Polytope.from_strips(reg.W, reg.y, (1 - 1e-3) * smallest, box=box).consistency().empty
    np.testing.assert_allclose(BoundRule(1.5, scaling).rows(gs, reg.joint), 1.5 * smallest)


def test_rule_refuses_what_cannot_be_consistent():
    with pytest.raises(InputError, match="factor must be finite and >= 1"):
        BoundRule(0.9)
    with pytest.raises(InputError, match="scaling must be one of"):
        BoundRule(2.0, "median")
    with pytest.raises(InputError, match="factor must be finite"):
        BoundRule(float("nan"))


def test_where_rows_sit_names_reversals_extremes_and_edges():
    """A 1-joint recording q = sin(t) over [0, 2 pi]: qd = cos t is 0 at t = pi/2 (a reversal),
    |tau| = |sin t| peaks there too (an extreme loses to the reversal); t = 0.01 is the start."""
    t = np.linspace(0, 2 * np.pi, 2001)
    q, tau = np.sin(t)[:, None], np.sin(t)[:, None] * np.cos(0.0)
    rows_t = np.array([np.pi / 2, 0.01, 2.5, np.pi + 0.3])
    reg = Regression(np.ones((4, 1)), np.zeros(4), np.zeros(4, int), np.zeros(4, int), rows_t, "inverse_dynamic",
                     ("a",))
    where = [r["where"] for r in where_rows_sit(reg, t, q, tau, range(4))]
    assert where == ["reversal or stop", "start or end", "elsewhere", "elsewhere"]


RULE_EXACT = """
[[estimators]]
method = "obe"
label = "OBE"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "wls"
label = "WLS"
regressions = ["filtered_dynamic"]

[exact]
regression = "filtered_dynamic"
{rule}
"""


def test_study_file_takes_a_rule_and_estimators_inherit_it(tmp_path):
    path = tmp_path / "rule.toml"
    rule = 'e_max_rule = { factor = 1.5, scaling = "wls_spread" }'
    path.write_text(tiny_study("rule", 1) + RULE_EXACT.format(rule=rule))
    cfg = load_study(path)
    assert cfg.exact.e_max is None and cfg.exact.e_max_rule == BoundRule(1.5, "wls_spread")
    obe = next(e for e in cfg.estimators if e.label == "OBE")
    assert obe.bound_from_exact and obe.e_max is None
    path.write_text(tiny_study("rule", 1) + RULE_EXACT.format(rule="e_max_rule = {}"))
    assert load_study(path).exact.e_max_rule == DEFAULT_RULE


@pytest.mark.parametrize("rule, extra, match", [
    ("e_max_rule = { factor = 0.5 }", "", r"exact\.e_max_rule\.factor: must be >= 1"),
    ('e_max_rule = { scaling = "median" }', "", r"exact\.e_max_rule\.scaling: must be one of"),
    ("e_max_rule = { factor = 2.0, margin = 1 }", "", r"exact\.e_max_rule\.margin: unknown key; a bound rule takes"),
    ("e_max_rule = { factor = nan }", "", r"exact\.e_max_rule\.factor: must be a finite number"),
    ("e_max_rule = { factor = 2.0 }\ne_max = 1.0", "", r"exact\.e_max_rule: and e_max are both given"),
    ("e_max_rule = { factor = 2.0 }", '\n[[estimators]]\nmethod = "obe"\nlabel = "OBE2"\n'
     'regressions = ["filtered_dynamic"]\ne_max = 1.0\n',
     r"e_max_rule: is given, but estimator 'OBE2' bounds the same filtered_dynamic rows by e_max = 1\.0"),
])
def test_study_file_refuses_a_bad_rule(tmp_path, rule, extra, match):
    path = tmp_path / "bad.toml"
    text = tiny_study("bad", 1) + RULE_EXACT.format(rule=rule)
    path.write_text(text.replace("[exact]", extra + "\n[exact]"))
    with pytest.raises(StudyError, match=match):
        load_study(path)


def test_an_estimator_without_a_bound_off_the_exact_regression_is_refused(tmp_path):
    path = tmp_path / "nobound.toml"
    path.write_text(tiny_study("nobound", 1, ("filtered_dynamic", "filtered_power")) + """
[[estimators]]
method = "obe"
label = "OBE"
regressions = ["filtered_dynamic", "filtered_power"]

[exact]
regression = "filtered_dynamic"
e_max_rule = { factor = 2.0 }
""")
    with pytest.raises(StudyError, match=r"estimators\[0\]\.e_max: is required .* on the \[exact\] regression alone"):
        load_study(path)


def test_measured_run_with_a_rule_states_what_holds_under_it(tmp_path):
    """A measured recording (the tiny simulated study's own), e_max = 2 x gamma*: the exact polytope's
    bounds are the rule's per-row bounds, the OBE runs on them and is certified, the verdict says the
    truth is unknown and what holds under the bound; a bound below gamma* gives the minimum number of
    outliers instead: a proven lower bound, and rows whose removal leaves the data consistent (the
    MILP's incumbent; on 1,600 rows the big-M relaxation rarely proves the minimum in its time limit)."""
    head = tiny_study("rulerun", 3)
    _, sim = run_study_text(tmp_path, "sim", head + RULE_EXACT.format(rule="e_max = 1.0"))
    text = measured_twin(head + RULE_EXACT.format(rule='e_max_rule = { factor = 2.0, scaling = "one" }'), sim,
                         tmp_path)
    _, r = run_study_text(tmp_path, "rulerun", text)
    ex = r.exact
    assert ex.evidence is not None and ex.rule == BoundRule(2.0, "one")
    np.testing.assert_allclose(ex.e_max, 2.0 * ex.evidence.one)
    assert ex.gamma_star == pytest.approx(0.5, rel=1e-6)  # 2 x the smallest: the bounds can shrink by half
    assert r.estimates[("OBE", "filtered_dynamic")].guaranteed and ex.certificates["OBE"].contains_polytope
    v = run_verdict(r)
    assert v.ok and "truth unknown (measured data): e_max = " in v.line and "2 x gamma*" in v.line

    low = text.replace('e_max_rule = { factor = 2.0, scaling = "one" }', f"e_max = {0.8 * ex.evidence.one!r}")
    low = low.replace('regressions = ["filtered_dynamic"]\n\n[[estimators]]\nmethod = "wls"',
                      f'regressions = ["filtered_dynamic"]\ne_max = {0.8 * ex.evidence.one!r}\n\n[[estimators]]\n'
                      'method = "wls"')
    _, r = run_study_text(tmp_path, "lowrun", low)
    o = r.exact.outliers
    assert o is not None and 1 <= o.lower_bound <= o.n_outliers == o.dropped.size
    kept = np.setdiff1d(np.arange(r.regressions["filtered_dynamic"].n_rows), o.dropped)
    reg = r.regressions["filtered_dynamic"]
    assert not Polytope.from_strips(reg.W[kept], reg.y[kept], 0.8 * ex.evidence.one * (1 + 1e-9),
                                    box=r.exact.polytope.box).consistency().empty
    v = run_verdict(r)
    assert not v.ok and "the data contradict the bound" in v.line and f"at least {o.lower_bound} row" in v.line


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(5))
def test_default_rule_holds_the_truth_on_mujoco_recordings(seed, tmp_path):
    """The default rule, 2 x gamma* with one bound on every row, on a UR5 recorded in MuJoCo (dry
    friction, armature, encoder, torque noise; tests/mujoco_recording.py), identified through the
    measured-data path with the low-speed window: the truth's largest row error is below the rule's
    bound, the exact polytope and the OBE contain the truth. Measured on seeds 0-8: the truth needed
    1.25-1.71 gamma*."""
    from boundid.experiments.recording import write_recording
    from boundid.studies.runner import run_study
    from mujoco_recording import record
    from test_mujoco_recording import MEASURED_STUDY

    rec = record(seed=seed)
    csv = write_recording(rec.recording(), tmp_path / "rec.csv")
    study = tmp_path / "rule.toml"
    study.write_text(MEASURED_STUDY.format(csv=csv.name).replace("e_max = 0.5\n", "")
                     + '\n[exact]\nregression = "inverse_dynamic"\ne_max_rule = {}\n')
    r = run_study(load_study(study))
    ex = r.exact
    theta = r.model.base.base(rec.theta_true)
    reg = r.regressions["inverse_dynamic"]
    ratio = np.abs(reg.y - reg.W @ theta) / ex.e_max
    print(f"seed {seed}: gamma* = {ex.evidence.one:.4g} N m, truth's largest error {ratio.max():.3f} x e_max")
    assert ratio.max() <= 1.0
    assert ex.polytope.contains(theta)
    assert r.estimates[("OBE", "inverse_dynamic")].contains(theta)


def test_contradicted_bound_on_unfiltered_rows_names_the_filter(tmp_path):
    """Inverse dynamic rows from unfiltered 16-bit encoder angles (qdd by double differences) contradict
    a bound the filtered rows respect; the message names [preprocessing] lowpass_cutoff_hz, the real fix,
    rather than a larger e_max alone."""
    text = tiny_study("unfiltered", 2, ("inverse_dynamic",)) + """
[[estimators]]
method = "wls"
label = "WLS"
regressions = ["inverse_dynamic"]

[exact]
regression = "inverse_dynamic"
e_max = 2.0
lp_bounds = false
"""
    _, r = run_study_text(tmp_path, "unfiltered", text)
    assert not r.exact.consistent
    assert "set [preprocessing] lowpass_cutoff_hz" in r.exact.errors["bounds"]


def test_bound_sweep_against_the_polytope_and_the_residuals():
    """Reference: Polytope.bounds at each factor's bounds and the residuals of the reference point,
    computed here; widths grow with the bound, and the Chebyshev fit of one bound on every row
    violates no row of that scaling from factor 1."""
    reg, box = _regression(seed=2)
    gs = gamma_star(reg, box)
    rows = bound_sweep(reg, box, gs, "wls_spread", {"Chebyshev": gs.chebyshev, "zero": np.zeros(4)},
                       factors=(1.2, 3.0))
    e = 3.0 * gs.smallest("wls_spread", reg.joint)
    b = Polytope.from_strips(reg.W, reg.y, e, box=box).bounds()
    assert rows[1]["mean width / prior"] == pytest.approx(np.mean((b.hi - b.lo) / (box[1] - box[0])), rel=1e-9)
    assert rows[0]["mean width / prior"] < rows[1]["mean width / prior"]
    assert rows[1]["rows zero violates"] == int(np.sum(np.abs(reg.y) > e))
    one = bound_sweep(reg, box, gs, "one", {"Chebyshev": gs.chebyshev}, factors=(1.01, 2.0))
    assert one[0]["rows Chebyshev violates"] == one[1]["rows Chebyshev violates"] == 0


def test_one_bound_per_joint_bounds_each_joints_rows(tmp_path):
    """[exact] e_max = [a, b]: each joint's rows take their joint's bound, in the polytope and in the OBE
    that inherits it (its set contains the exact polytope, certified); the page states the bounds by joint;
    the truth's ratio is computed row by row against them."""
    text = tiny_study("perjoint", 1) + RULE_EXACT.format(rule="e_max = [6.0, 3.0]")
    _, r = run_study_text(tmp_path, "perjoint", text)
    reg, ex = r.regressions["filtered_dynamic"], r.exact
    np.testing.assert_array_equal(ex.e_max, np.where(reg.joint == 0, 6.0, 3.0))
    np.testing.assert_array_equal(ex.polytope.e_max, ex.e_max)
    assert ex.bound_text() == "6, 3 N m by joint"
    ratio = np.abs(reg.y - reg.W @ r.model.theta_true) / np.where(reg.joint == 0, 6.0, 3.0)
    assert ex.truth_error_ratio == pytest.approx(ratio.max())
    assert ex.certificates["OBE"].contains_polytope


@pytest.mark.parametrize("e_max, match", [
    ("[6.0]", "lists 1 bounds but the direct_drive model has 2 joints"),
    ("[6.0, -1.0]", "must list one finite number > 0 per joint"),
    ("[6.0, nan]", "must list one finite number > 0 per joint"),
    ('{ a = 1 }', "a list of one per joint; a rule"),
])
def test_a_bad_per_joint_bound_is_refused(tmp_path, e_max, match):
    path = tmp_path / "bad.toml"
    path.write_text(tiny_study("bad", 1) + RULE_EXACT.format(rule=f"e_max = {e_max}"))
    with pytest.raises(StudyError, match=match):
        load_study(path)


def test_relaxed_q_bounds_the_parameters_with_q_outliers_on_the_page(tmp_path):
    """[exact] relaxed_q = 2 on 40 rows of 9 parameters with two planted outliers: the exact polytope is
    empty, the minimum number of outliers is 2 and the q-relaxed bounds are those of the polytope without
    the planted rows, which here is the only way to satisfy all others (reference: Polytope.bounds of the
    rows kept); the page's table shows them."""
    from boundid.report.html import Page
    from boundid.report.study_page import _relaxed_table
    from boundid.studies.progress import QUIET
    from boundid.studies.runner import exact_optima

    path = tmp_path / "rel.toml"
    path.write_text(tiny_study("rel", 1) + RULE_EXACT.format(rule="e_max = 0.5\nrelaxed_q = 2"))
    cfg = load_study(path)
    rng = np.random.default_rng(3)
    from boundid.studies.registry import make_robot

    model = make_robot(cfg.robot, cfg.robot_options)
    W = rng.normal(size=(40, model.p))
    y = W @ model.theta_true + rng.uniform(-0.5, 0.5, 40)
    y[[7, 23]] += [30.0, -30.0]
    reg = Regression(W, y, np.zeros(40, dtype=int), np.arange(40), np.arange(40) * 0.01, "filtered_dynamic",
                     model.param_names)
    ex = exact_optima(cfg, reg, model, {}, QUIET, 0.5)
    assert not ex.consistent and ex.outliers.n_outliers == 2 and set(ex.outliers.dropped) == {7, 23}
    kept = np.setdiff1d(np.arange(40), [7, 23])
    ref = Polytope.from_strips(W[kept], y[kept], 0.5, box=ex.polytope.box).bounds()
    rb = ex.relaxed
    assert rb.q == 2 and rb.lo_proven.all() and rb.hi_proven.all()
    np.testing.assert_allclose(rb.lo, ref.lo, atol=1e-6 * np.ptp(ex.polytope.box))
    np.testing.assert_allclose(rb.hi, ref.hi, atol=1e-6 * np.ptp(ex.polytope.box))
    page = Page("t")
    page.section("s")
    _relaxed_table(page, SimpleNamespace(exact=ex, model=model))
    text = page.to_markdown()
    assert "at most q = 2 rows" in text and f"exact where proven ({model.p} of {model.p} parameters)" in text
