"""The physical-consistency stage of a study: physically consistent exact bounds beside the plain
ones, and the physical consistency of statistical estimates."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from boundid.estimators import ols
from boundid.models import H4Robot
from boundid.sets import Polytope
from boundid.studies.physical_stage import physical_stage


def h4_problem(N=60, e=2.0, seed=3):
    robot = H4Robot()
    rng = np.random.default_rng(seed)
    g = robot.geometry
    q = robot.inverse_kinematics(rng.uniform(g.workspace_low, g.workspace_high, (N, 4)))
    W = robot.regressor(q, rng.normal(0, 1, (N, 4)), rng.normal(0, 5, (N, 4))).reshape(-1, 14)
    y = W @ robot.theta_true + rng.uniform(-e, e, W.shape[0])
    c = robot.theta_true
    h = np.abs(c) + 0.5
    return robot, W, y, e, (c - h, c + h)


def test_h4_physical_bounds_equal_one_linprog_per_side():
    """H4 (linear constraints: every parameter >= 0): each physically consistent bound equals a
    scipy linprog (HiGHS) solve over all strips, the prior box and theta >= 0 (independent: no
    working set, no scaling); the physical intervals lie inside the plain ones, the truth inside
    both, and the table marks narrower intervals."""
    robot, W, y, e, box = h4_problem()
    P = Polytope(W, y, e, box=box)
    res = physical_stage(P, robot.physical_constraints(), robot.param_names, {}, robot.theta_true)
    assert res.error is None and res.method == "LP (simplex)"
    A_ub, b_ub = np.vstack([W, -W]), np.concatenate([y + e, e - y])
    bounds = list(zip(np.maximum(box[0], 0.0), box[1], strict=True))
    t = res.intervals
    for j in range(14):
        c = np.eye(14)[j]
        lo = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds).fun
        hi = -linprog(-c, A_ub=A_ub, b_ub=b_ub, bounds=bounds).fun
        scale = t["plain_hi"].iloc[j] - t["plain_lo"].iloc[j]
        assert abs(t["phys_lo"].iloc[j] - lo) <= 1e-7 * scale and abs(t["phys_hi"].iloc[j] - hi) <= 1e-7 * scale
    assert np.all(t["phys_lo"] >= t["plain_lo"] - 1e-12) and np.all(t["phys_hi"] <= t["plain_hi"] + 1e-12)
    assert (t["truth_inside"] == "yes").all() and np.all(t["phys_lo"] >= -1e-12)
    narrower = (t["phys_hi"] - t["phys_lo"]) < (1 - 1e-6) * (t["plain_hi"] - t["plain_lo"])
    assert list(t["narrower"]) == ["yes" if n else "no" for n in narrower]
    assert res.narrower == int(narrower.sum()) and 0 < res.mean_width_ratio <= 1


def test_statistical_estimate_with_negative_friction_is_flagged():
    """An OLS centre pushed below 0 in one friction coefficient is "not consistent", with that
    constraint named and margin = -(its violation); the truth as an estimate is consistent."""
    robot, W, y, e, box = h4_problem()
    est = ols(W, y, names=robot.param_names)
    j = robot.param_names.index("Fv2")
    est.center = est.center.copy()
    est.center[j] = -0.25
    truth_est = ols(W, W @ robot.theta_true + 1e-9 * np.sin(np.arange(W.shape[0])), names=robot.param_names)
    res = physical_stage(Polytope(W, y, e, box=box), robot.physical_constraints(), robot.param_names,
                         {"OLS": est, "noise-free OLS": truth_est})
    row = res.estimates.loc["OLS"]
    assert row["consistent"] == "no" and "Fv2" in row["worst"] and row["margin"] <= -0.25 + 1e-12
    assert res.estimates.loc["noise-free OLS", "consistent"] == "yes"
    assert res.intervals["truth_inside"].isna().all()


def test_data_contradicting_physics_is_reported_not_raised():
    """Strips that admit only a negative friction coefficient: the plain set is not empty, the
    physical one is; the stage returns the error (InfeasibleDataError, naming both gamma*)."""
    robot = H4Robot()
    W = np.zeros((2, 14))
    j = robot.param_names.index("Fv1")
    W[:, j] = 1.0
    y = np.array([-1.0, -1.2])
    res = physical_stage(Polytope(W, y, 0.3, box=(np.full(14, -5.0), np.full(14, 5.0))),
                         robot.physical_constraints(), robot.param_names, {})
    assert res.bounds is None and res.error.startswith("InfeasibleDataError") and "gamma*" in res.error
