"""Benchmark of the physically consistent feasible set (boundid.sets.physical) and estimates."""

from __future__ import annotations

import time

import cvxpy as cp
import numpy as np
import pandas as pd

from boundid.bench.bench_sets import PAPER_STUDIES, _load, _study_regression
from boundid.estimators import OBE, ols
from boundid.estimators.physical import physical_intersection, physical_least_squares
from boundid.models import BaseParameterModel
from boundid.models.direct_drive import PHYSICAL, planar_arm_urdf
from boundid.sets import Box
from boundid.sets.physical import PhysicalSet, column_bounds
from boundid.sets.sdp import CLARABEL_LINALG

GOALS = """
Physically consistent exact bounds: min and max of every parameter over
{strips} ∩ {prior box} ∩ {the model's physical constraints}, against the plain exact (LP) bounds
of the same regression, on:

* the two studies' exact-stage regressions (built by the study machinery: `load_study`, `acquire`,
  `build_regressions`, `prior_box`; cached under .cache/boundid like the sets benchmark): the H4
  (14 parameters, all >= 0: an LP, HiGHS) and the direct-drive arm (9 parameters, a rotated
  second-order cone: Clarabel, constraint generation, dual-certified bounds);
* URDF arms in base parameters with one pseudo-inertia LMI per link on the lifted standard
  parameters: the direct-drive arm written as a 2-link URDF and the UR5 (48 base, 72 standard
  parameters), on exact states within the joint limits with uniform torque noise (no simulation
  needed for a regression: y = Y(q, qd, qdd) beta + e).

One `bounds` row per case: `time_s` = physically consistent bounds (without the plain LP bounds
they start from), `plain_time_s` = the plain LP bounds, `ref_time_s` = the same optima as one
cvxpy problem per bound with every strip at once and no scaling (Clarabel; skipped for the H4 LP
and the UR5), `max_dev` = largest difference to that reference in half-widths;
`width_ratio` = mean over parameters of the physical width over the plain width. Then one row per
parameter (`plain_lo`..`phys_hi`, `truth`), and the physically consistent estimates on the study
regressions: OLS under the constraints, and the OBE (factorized, volume, the study's bound and
prior box) intersected with the physical set (`time_s` the physical step, `plain_time_s` the raw
estimator's fit; `detail`: whether the raw centre is physical).
Every row records the 1-minute load average (2 shared cores).
"""


def _row(case, what, **kw):
    base = {"case": case, "what": what, "parameter": "", "time_s": np.nan, "plain_time_s": np.nan,
            "ref_time_s": np.nan, "max_dev": np.nan, "width_ratio": np.nan, "plain_lo": np.nan, "plain_hi": np.nan,
            "phys_lo": np.nan, "phys_hi": np.nan, "truth": np.nan, "load_avg": _load(), "detail": ""}
    return {**base, **kw}


def _reference(W, y, e, cons, box):
    """Every bound as one cvxpy problem with all strips (no constraint generation, no scaling)."""
    x = cp.Variable(cons.dim)
    theta = cons.lift @ x if cons.is_lifted else x
    parts = [cp.abs(y - W @ theta) <= e]
    if box is not None:
        parts += [theta >= box[0], theta <= box[1]]
    if cons.linear.m:
        parts.append(cons.linear.A @ x <= cons.linear.b)
    parts += [cp.SOC(c.f @ x + c.d, c.G @ x + c.g) for c in cons.cones]
    for L in cons.lmis:
        M = L.F0 + sum(x[i] * L.F[i] for i in range(cons.dim) if np.any(L.F[i]))
        parts.append(0.5 * (M + M.T) >> 0)
    p = W.shape[1]
    lo, hi = np.empty(p), np.empty(p)
    for j in range(p):
        lo[j] = cp.Problem(cp.Minimize(theta[j]), parts).solve(solver=cp.CLARABEL, **CLARABEL_LINALG)
        hi[j] = cp.Problem(cp.Maximize(theta[j]), parts).solve(solver=cp.CLARABEL, **CLARABEL_LINALG)
    return lo, hi


def _bounds_rows(case, W, y, e, cons, box, truth, names, reference: bool, per_parameter: bool):
    S = PhysicalSet(W, y, e, cons, box=box)
    t0 = time.perf_counter()
    pb = S.plain.bounds()
    t_plain = time.perf_counter() - t0
    t0 = time.perf_counter()
    b = S.bounds()
    t_phys = time.perf_counter() - t0
    c = S.consistency()
    ref_t = dev = np.nan
    if reference:
        t0 = time.perf_counter()
        lo, hi = _reference(W, y, e, cons, box)
        ref_t = time.perf_counter() - t0
        dev = float(max(np.max(np.abs(lo - b.lo) / b.half_width), np.max(np.abs(hi - b.hi) / b.half_width)))
    inside = bool(np.all((b.lo <= truth + 1e-9 * np.abs(truth)) & (truth <= b.hi + 1e-9 * np.abs(truth))))
    tightened = int(np.sum((b.hi - b.lo) < (1 - 1e-6) * (pb.hi - pb.lo)))
    info = b.info
    detail = (f"{b.method}, certificate {b.certificate}; N = {S.plain.n_strips}, p = {S.dim}, {len(cons)} constraints; "
              f"gamma* {c.gamma_plain:.4f} plain, {c.gamma:.4f} physical; {tightened} of {S.dim} intervals narrower; "
              f"truth inside: {inside}; min physical lower bound of a >= 0 parameter "
              f"{np.min(b.lo[np.isfinite(_nonneg_lo(cons))]) if np.any(np.isfinite(_nonneg_lo(cons))) else np.nan:.3g}")
    if "rounds" in info:
        detail += (f"; {info['rounds']} rounds, {info['solves']} conic solves, {info['working_rows']} strips in the "
                   f"working set, primal excess {info['primal_excess']:.2g}, dual gap {info['dual_gap']:.2g}")
    rows = [_row(case, "bounds", time_s=t_phys, plain_time_s=t_plain, ref_time_s=ref_t, max_dev=dev,
                 width_ratio=float(np.mean((b.hi - b.lo) / (pb.hi - pb.lo))), detail=detail)]
    if per_parameter:
        for j, nm in enumerate(names):
            rows.append(_row(case, "interval", parameter=nm, plain_lo=pb.lo[j], plain_hi=pb.hi[j], phys_lo=b.lo[j],
                             phys_hi=b.hi[j], truth=truth[j],
                             width_ratio=(b.hi[j] - b.lo[j]) / (pb.hi[j] - pb.lo[j])))
    return rows


def _nonneg_lo(cons):
    """0 for the parameters a constraint row keeps >= 0, NaN for the others."""
    return np.where(column_bounds(cons)[0] == 0, 0.0, np.nan)


def _estimate_rows(case, W, y, e, cons, box, names):
    rows = []
    t0 = time.perf_counter()
    est = physical_least_squares(W, y, cons, names=names)
    t = time.perf_counter() - t0
    raw = ols(W, y, names=names)
    rows.append(_row(case, "OLS physical", time_s=t, plain_time_s=raw.time_s,
                     detail=f"raw centre physical: {est.info['unconstrained_consistent']}; active constraints: "
                            f"{', '.join(est.info['active_constraints']) or 'none'}"))
    center, half = 0.5 * (box[0] + box[1]), 0.5 * (box[1] - box[0])
    t0 = time.perf_counter()
    obe = OBE(len(center), prior=Box.from_center(center, half), names=names).fit(W, y, e)
    t_obe = time.perf_counter() - t0
    t0 = time.perf_counter()
    oi = physical_intersection(obe, cons)
    t = time.perf_counter() - t0
    neg = [nm for nm, lo, clo in zip(names, obe.intervals[0], _nonneg_lo(cons), strict=True) if clo == 0 and lo < 0]
    rows.append(_row(case, "OBE ∩ physics", time_s=t, plain_time_s=t_obe,
                     width_ratio=float(np.mean(np.subtract(*oi.intervals[::-1]) / np.subtract(*obe.intervals[::-1]))),
                     detail=f"raw centre physical: {oi.info['raw_consistent']}; raw lower bounds below 0: "
                            f"{', '.join(neg) or 'none'}; certificate {oi.info['physical']['certificate']}"))
    return rows


def _study_rows(quick: bool):
    from boundid.studies.config import load_study
    from boundid.studies.registry import make_robot

    rows = []
    for path in PAPER_STUDIES:   # the UR5 has its own rows (_urdf_rows)
        name, W, y, e, box = _study_regression(path)
        cfg = load_study(path)
        model = make_robot(cfg.robot, cfg.robot_options)
        cons = model.physical_constraints()
        case = f"study {name} (N={W.shape[0]}, p={W.shape[1]})"
        rows += _bounds_rows(case, W, y, e, cons, box, model.theta_true, model.param_names,
                             reference=not quick and not cons.is_linear, per_parameter=True)
        rows += _estimate_rows(case, W, y, e, cons, box, model.param_names)
    return rows


def _urdf_states(view, N, e, seed):
    rng = np.random.default_rng(seed)
    lim = view.robot.limits
    q = lim.sample_positions(rng, N)
    qd = rng.uniform(-1, 1, (N, view.n_joints)) * np.minimum(lim.velocity, 3.0)
    qdd = rng.uniform(-1, 1, (N, view.n_joints)) * np.minimum(lim.acceleration, 10.0)
    W = view.regressor(q, qd, qdd).reshape(-1, view.p)
    return W, W @ view.theta_true + rng.uniform(-e, e, W.shape[0])


def _urdf_rows(quick: bool):
    import tempfile

    from boundid.models import UrdfRobot

    rows = []
    with tempfile.TemporaryDirectory() as folder:
        planar = BaseParameterModel(UrdfRobot(planar_arm_urdf(folder), gravity=[0.0, 0.0, -PHYSICAL["g"]]))
        W, y = _urdf_states(planar, 200, 20.0, seed=3)
        rows += _bounds_rows(f"URDF 2-link arm, base parameters (N={W.shape[0]}, p={planar.p}, +-20 N m)", W, y, 20.0,
                             planar.physical_constraints(), None, planar.theta_true, planar.param_names,
                             reference=True, per_parameter=False)
    if not quick:
        view = BaseParameterModel(UrdfRobot("ur5", viscous=0.4, coulomb=1.2))
        W, y = _urdf_states(view, 300, 2.0, seed=1)
        rows += _bounds_rows(f"URDF UR5, base parameters (N={W.shape[0]}, p={view.p}, +-2 N m)", W, y, 2.0,
                             view.physical_constraints(), None, view.theta_true, view.param_names,
                             reference=False, per_parameter=False)
    return rows


def run(quick: bool = False) -> pd.DataFrame:
    """The two studies' regressions (quick: without the all-strips cvxpy reference) and the URDF
    cases (quick: the 2-link arm only). Same data, same numbers: every draw is seeded."""
    rows = _study_rows(quick) + _urdf_rows(quick)
    return pd.DataFrame(rows)
