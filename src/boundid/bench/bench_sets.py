"""Benchmark of the exact feasible-set geometry (boundid.sets.polytope and boundid.sets.sdp)."""

from __future__ import annotations

import hashlib
import os
import re
import resource
import time
from pathlib import Path

import cvxpy as cp
import numpy as np
import pandas as pd
from scipy.optimize import linprog

from boundid.bench.goals import Goal
from boundid.sets import Polytope, log_unit_ball_volume, sdp
from boundid.sets.polytope import LP_TOL, TOUCH_TOL, WorkingSetLP

#: where the study-scale regressions are cached (git-ignored; BOUNDID_CACHE overrides)
CACHE = Path(os.environ.get("BOUNDID_CACHE", ".cache/boundid"))
#: the two papers' studies; the previous-method references run on these only (at p = 22 alone they
#: would take minutes)
PAPER_STUDIES = ("studies/h4_obe.toml", "studies/direct_drive_rls.toml")
STUDIES = (*PAPER_STUDIES, "studies/ur5_urdf.toml")

GOALS = """
Goals (exact stages at scale):

* Exact parameter bounds of a p = 14 polytope with N = 1e5 strips in <= 1.5 s, and >= 50x faster
  than 2p independent `scipy.optimize.linprog` calls (HiGHS) on the full LP. Both references
  (28 independent `linprog` calls; one cvxpy problem with a parametrised objective solved 28 times
  by Clarabel) run in the same process on the same data; `ratio` = reference time / our time
  (speed-up), `max_dev` = largest deviation of the reference bounds from ours. The cvxpy
  reference is skipped at N = 1e5 (380 s there in a trial run; the linprog one still runs).
* SDP ellipsoids (p = 14, m = 50, 200, 1000 strips) in <= 3 s each, including the LPs they need
  (bounds, redundancy removal, strip tightening). References: the inscribed ellipsoid as one
  cvxpy problem with every strip (no constraint generation); the S-procedure on all raw strips
  (no tightening, no redundancy removal). `ratio` = reference time / our time; `log_vol_per_axis`
  = ln vol / p (the outer ellipsoids differ in size: smaller is better).

Goals (study scale):

* Study scale: the exact stage (LP bounds + SDP outer + inner + John) of each study <= 5 s, on
  the study's own regression (built by the study machinery, cached under .cache/boundid); each
  study's stage runs 3 times on a fresh polytope and its row is the median run, with the range
  of the 3 in `detail` (the shared machine's speed varies by a third from minute to minute).
  The stage runs as in a study (:func:`boundid.sets.sdp.polytope_ellipsoids`: the inscribed,
  outer and John ellipsoids one after the other, the outer one's LPs on two threads); `detail`
  gives each one's own wall time and the stage's CPU time. The outer ellipsoid is the
  S-procedure by column generation over every tightened strip; its reference in the same run is
  the previous method (one LP per candidate side for redundancy removal, 2 LPs per non-redundant
  strip for tightening, then one S-procedure on all of them): `ratio` = reference time / our
  time; `log_vol_per_axis` of both (ours may only be smaller).
  The three studies: H4 (p = 14), direct-drive arm (p = 9), UR5 from its URDF (p = 22, 2,577
  strips; the goal was set before this study existed, and its previous-method reference is not
  run: at p = 22 it alone would take minutes).
* Redundancy removal, output-sensitive (goal 1 of the study-scale speed work): `nonredundant()` on each study's
  regression against the previous method in the same run (one LP per side the LP box reaches,
  sequential elimination): `ratio` = reference time / our time; `detail` says whether both
  return the same strips.
* LP bounds at recording scale (p = 14): N = 1e6 <= 1 s and N = 1e7 <= 8 s within 4 GB.
  `peak_rss_gb` is the process's peak resident memory after the case (10^9 bytes); `detail` the
  strips left by the box screen. The consistency LP (gamma*) on the same data follows each case
  (no goal; it is screened by a box too). Every row records the 1-minute load average when it ran
  (the machine has 2 cores).
"""


def _case(name: str) -> dict:
    return {"case": re.escape(name)}


GOAL_CHECKS = (
    Goal("exact LP bounds: time", {**_case("bounds p=14 N=100000"), "reference": "scipy linprog.*"}, "time_s", "<=",
         1.5, "s", size="{case}"),
    Goal("exact LP bounds: speed-up over 2p scipy linprog calls",
         {**_case("bounds p=14 N=100000"), "reference": "scipy linprog.*"}, "ratio", ">=", 50.0, "x", size="{case}"),
    *(Goal(f"{kind} ellipsoid (with its LPs): time", _case(f"{kind} ellipsoid p=14 m={m}"), "time_s", "<=", 3.0,
           "s", size="{case}") for m in (50, 200, 1000) for kind in ("inner", "outer", "John")),
    *(Goal("study exact stage (LP bounds, SDP outer, inner, John): time",
           {"case": re.escape(f"study {s} exact stage (") + ".*"}, "time_s", "<=", 5.0, "s", size="{case}")
      for s in ("h4_obe", "direct_drive_rls", "ur5_urdf")),
    Goal("LP bounds at recording scale: time", _case("bounds p=14 N=1e+06"), "time_s", "<=", 1.0, "s",
         size="{case}"),
    Goal("LP bounds at recording scale: time", _case("bounds p=14 N=1e+07"), "time_s", "<=", 8.0, "s",
         size="{case}"),
    Goal("LP bounds at recording scale: peak memory", _case("bounds p=14 N=1e+07"), "peak_rss_gb", "<=", 4.0, "GB",
         size="{case}"),
)


def _problem(rng, p, N):
    W = rng.normal(size=(N, p))
    e = np.ones(N)
    y = W @ rng.normal(size=p) + rng.uniform(-1, 1, N)
    return W, y, e


def _linprog_bounds(W, y, e):
    p = W.shape[1]
    A_ub, b_ub = np.vstack([W, -W]), np.concatenate([y + e, e - y])
    lo, hi = np.empty(p), np.empty(p)
    for j in range(p):
        c = np.zeros(p)
        c[j] = 1.0
        lo[j] = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=(None, None), method="highs").fun
        hi[j] = -linprog(-c, A_ub=A_ub, b_ub=b_ub, bounds=(None, None), method="highs").fun
    return lo, hi


def _cvxpy_bounds(W, y, e):
    p = W.shape[1]
    x, c = cp.Variable(p), cp.Parameter(p)
    prob = cp.Problem(cp.Minimize(c @ x), [cp.abs(y - W @ x) <= e])
    lo, hi = np.empty(p), np.empty(p)
    for j in range(p):
        c.value = np.eye(p)[j]
        lo[j] = prob.solve(solver=cp.CLARABEL)
        c.value = -np.eye(p)[j]
        hi[j] = -prob.solve(solver=cp.CLARABEL)
    return lo, hi


def _timed(f, *args):
    t0 = time.perf_counter()
    out = f(*args)
    return out, time.perf_counter() - t0


def _bounds_rows(sizes, p, rng, cvxpy_max_n):
    rows = []
    for N in sizes:
        W, y, e = _problem(rng, p, N)
        b, t_ours = _timed(lambda W, y, e: Polytope.from_strips(W, y, e).bounds(), W, y, e)
        refs = [("scipy linprog (HiGHS), 2p independent calls", _linprog_bounds)]
        if N <= cvxpy_max_n:
            refs.append(("cvxpy + Clarabel, 2p solves", _cvxpy_bounds))
        for name, f in refs:
            (lo, hi), t_ref = _timed(f, W, y, e)
            dev = max(np.abs(lo - b.lo).max(), np.abs(hi - b.hi).max())
            rows.append({"case": f"bounds p={p} N={N}", "method": "constraint generation (highspy)",
                         "time_s": t_ours, "reference": name, "ref_time_s": t_ref, "ratio": t_ref / t_ours,
                         "max_dev": dev, "log_vol_per_axis": np.nan,
                         "detail": f"{b.info['working_rows']} rows in working set"})
    return rows


def _raw(P, b):
    """S-procedure on every raw strip (no tightening, no redundancy removal), scaled frame."""
    cb, hb = b.center, b.half_width
    g = P.W * hb
    nrm = np.linalg.norm(g, axis=1)
    G = np.vstack([np.eye(P.dim), g / nrm[:, None]])
    mid = np.concatenate([np.zeros(P.dim), (P.y - P.W @ cb) / nrm])
    half = np.concatenate([np.ones(P.dim), P.e_max / nrm])
    A0, *_ = sdp._s_procedure(G, mid, half, [], False, "raw S-procedure")
    # ln vol = ln vol(unit ball) - (1/2) ln det A0 + sum ln hb  (back to parameter units)
    return log_unit_ball_volume(P.dim) - 0.5 * np.linalg.slogdet(A0)[1] + np.sum(np.log(hb))


def _full_inner(P):
    """Inscribed ellipsoid as one cvxpy problem with every strip (scaled frame)."""
    b = P.bounds()
    cb, hb = b.center, b.half_width
    A = (P.W / P.e_max[:, None]) * hb
    c = (P.y - P.W @ cb) / P.e_max
    B, x0 = cp.Variable((P.dim, P.dim), PSD=True), cp.Variable(P.dim)
    prob = cp.Problem(cp.Maximize(cp.log_det(B)), [cp.norm(A @ B, 2, axis=1) + cp.abs(A @ x0 - c) <= 1])
    prob.solve(solver=cp.CLARABEL)
    return prob.value


def _sdp_rows(sizes, p, rng):
    rows = []
    for m in sizes:
        W, y, e = _problem(rng, p, m)
        P = Polytope.from_strips(W, y, e)
        P.bounds()
        fresh = Polytope.from_strips(W, y, e)
        inner = sdp.inner_ellipsoid(fresh)
        _, t_ref = _timed(_full_inner, P)
        rows.append({"case": f"inner ellipsoid p={p} m={m}", "method": f"constraint generation, {inner.solver}",
                     "time_s": inner.time_s, "reference": "one SDP with every strip", "ref_time_s": t_ref,
                     "ratio": t_ref / inner.time_s, "max_dev": np.nan,
                     "log_vol_per_axis": inner.ellipsoid.log_volume() / p,
                     "detail": f"{inner.info['working_sides']} sides in working set"})
        fresh = Polytope.from_strips(W, y, e)
        outer = sdp.outer_ellipsoid(fresh)
        raw_logvol, t_ref = _timed(_raw, P, P.bounds())
        rows.append({"case": f"outer ellipsoid p={p} m={m}", "method": "S-procedure, tightened non-redundant",
                     "time_s": outer.time_s, "reference": "S-procedure on all raw strips", "ref_time_s": t_ref,
                     "ratio": t_ref / outer.time_s, "max_dev": np.nan,
                     "log_vol_per_axis": outer.ellipsoid.log_volume() / p,
                     "detail": f"{len(outer.strips)} strips used; raw-strip S-procedure ln vol / p = "
                               f"{raw_logvol / p:.3f}"})
        fresh = Polytope.from_strips(W, y, e)
        john = sdp.john_outer(fresh)
        rows.append({"case": f"John ellipsoid p={p} m={m}", "method": "p x inner", "time_s": john.time_s,
                     "reference": "", "ref_time_s": np.nan, "ratio": np.nan, "max_dev": np.nan,
                     "log_vol_per_axis": john.ellipsoid.log_volume() / p, "detail": ""})
    return rows


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _study_regression(path: str):
    """(name, W, y, e_max, box, theta_true) of a study's exact-stage regression, built by the
    study machinery once and cached to CACHE/<name>.npz (rebuilt when the study file changes)."""
    text = Path(path).read_bytes()
    key = hashlib.sha256(text).hexdigest()[:16]
    f = CACHE / f"{Path(path).stem}-{key}.npz"
    if not f.exists():
        from boundid.studies.config import load_study
        from boundid.studies.data import acquire
        from boundid.studies.registry import make_robot
        from boundid.studies.runner import build_regressions, prior_box

        cfg = load_study(path)
        model = make_robot(cfg.robot, cfg.robot_options)
        data = acquire(cfg, model, np.random.default_rng(cfg.seed))
        reg = build_regressions(model, data.recording, cfg.preprocessing, cfg.regressions)[cfg.exact.regression]
        c, h = prior_box(model, cfg.prior)
        CACHE.mkdir(parents=True, exist_ok=True)
        np.savez(f, W=reg.W, y=reg.y, e_max=cfg.exact.e_max, lo=c - h, hi=c + h)
    d = np.load(f)
    return Path(path).stem, d["W"], d["y"], float(d["e_max"]), (d["lo"], d["hi"])


def _previous_nonredundant(P: Polytope) -> np.ndarray:
    """The previous redundancy removal, kept here as the reference: one LP per side the LP box
    reaches (side relaxed, sequential elimination over the whole data)."""
    P.bounds()
    origin, scale = P.box_frame()
    blk = P._strip_block(P._frame)
    up_s, lo_s = blk.up.copy(), blk.lo.copy()
    G = P.W * scale / P._frame.n[:, None]
    reach = np.abs(G).sum(axis=1)
    up_c, lo_c = reach > up_s - TOUCH_TOL * (1 + np.abs(up_s)), -reach < lo_s + TOUCH_TOL * (1 + np.abs(lo_s))
    eng = WorkingSetLP([blk], *P._col_bounds(P._frame), seed=[(0, P._engine.ws_rows(0))], tol=LP_TOL)
    blk.up[~up_c], blk.lo[~lo_c] = np.inf, -np.inf
    for k in np.flatnonzero(~up_c | ~lo_c):
        if eng.in_ws[0][k]:
            eng.set_bounds(0, k, blk.lo[k], blk.up[k])
    keep = np.zeros(P.n_strips, dtype=bool)
    for k in np.flatnonzero(up_c | lo_c):
        for side, cand, bound in ((1.0, up_c[k], up_s[k]), (-1.0, lo_c[k], lo_s[k])):
            if not cand:
                continue
            eng.set_bounds(0, k, blk.lo[k], bound + 1.0) if side > 0 else eng.set_bounds(0, k, bound - 1.0, blk.up[k])
            v = side * float(G[k] @ eng.minimize(-side * G[k])[0])
            if v > side * bound + TOUCH_TOL * (1 + abs(bound)):
                keep[k] = True
                eng.set_bounds(0, k, blk.lo[k], up_s[k]) if side > 0 else eng.set_bounds(0, k, lo_s[k], blk.up[k])
            else:
                eng.set_bounds(0, k, blk.lo[k], np.inf) if side > 0 else eng.set_bounds(0, k, -np.inf, blk.up[k])
    return np.flatnonzero(keep)


def _previous_outer(P: Polytope):
    """The previous outer-ellipsoid method, kept here as the reference: the previous redundancy
    removal, each non-redundant strip tightened by 2 LPs, then one S-procedure on all of them
    with the LP box. Returns (ln vol, strips, time of the redundancy removal)."""
    b = P.bounds()
    origin, scale = P.box_frame()
    G = P.W * scale / P._frame.n[:, None]
    t0 = time.perf_counter()
    nr = _previous_nonredundant(P)
    t_nr = time.perf_counter() - t0
    full = P._engine
    lo = np.array([float(G[k] @ full.minimize(G[k])[0]) for k in nr]) - LP_TOL
    hi = np.array([float(G[k] @ full.minimize(-G[k])[0]) for k in nr]) + LP_TOL
    zlo, zhi = (b.lo - origin) / scale, (b.hi - origin) / scale
    Gs = np.vstack([np.eye(P.dim), G[nr]])
    lo, hi = np.concatenate([zlo, lo]), np.concatenate([zhi, hi])
    A0, *_ = sdp._s_procedure(Gs, 0.5 * (lo + hi), 0.5 * (hi - lo), [], False, "previous outer")
    return log_unit_ball_volume(P.dim) - 0.5 * np.linalg.slogdet(A0)[1] + np.sum(np.log(scale)), nr, t_nr


#: runs of each study's exact stage; its row reports the median run, with the range
STUDY_RUNS = 3


def _exact_stage(W, y, e, box) -> dict:
    """One run of the exact stage on a fresh polytope, as a study runs it: the LP bounds, then
    :func:`boundid.sets.sdp.polytope_ellipsoids` (the inscribed, outer and John ellipsoids).
    {stage: (wall time, result)}, and "total": (wall time, CPU time of the process)."""
    P = Polytope.from_strips(W, y, e, box=box)
    w0, c0 = time.perf_counter(), time.process_time()
    bounds = P.bounds()
    t = {"LP bounds": (time.perf_counter() - w0, bounds)}
    for name, (out, seconds) in sdp.polytope_ellipsoids(P).items():
        if isinstance(out, Exception):
            raise out
        t[f"SDP {'John' if name == 'john' else name}"] = (seconds, out)
    t["total"] = (time.perf_counter() - w0, time.process_time() - c0)
    return t


def _study_rows(paths, reference: bool, runs: int = STUDY_RUNS):
    rows = []
    for path in paths:
        name, W, y, e, box = _study_regression(path)
        N, p = W.shape
        stages = sorted((_exact_stage(W, y, e, box) for _ in range(runs)), key=lambda t: t["total"][0])
        totals = [t["total"][0] for t in stages]
        t = stages[len(stages) // 2]
        total, cpu = t["total"]
        outer = t["SDP outer"][1]
        R = Polytope.from_strips(W, y, e, box=box)
        R.bounds()
        t0 = time.perf_counter()
        ours_nr = R.nonredundant()
        t_nr = time.perf_counter() - t0
        ref_t, ref_lv, detail, nr, ref_nr_t = np.nan, np.nan, "", None, np.nan
        if reference and path in PAPER_STUDIES:
            Q = Polytope.from_strips(W, y, e, box=box)
            Q.bounds()
            t0 = time.perf_counter()
            ref_lv, nr, ref_nr_t = _previous_outer(Q)
            ref_t = time.perf_counter() - t0
            detail = f"previous method: {len(nr)} non-redundant strips, ln vol / p = {ref_lv / p:.6f}; "
        rows.append({"case": f"study {name} exact stage (N={N}, p={p})",
                     "method": "LP bounds, then the SDP inner, outer (LPs on 2 threads) and John ellipsoids",
                     "time_s": total, "reference": "", "ref_time_s": np.nan, "ratio": np.nan, "max_dev": np.nan,
                     "log_vol_per_axis": np.nan, "load_avg": _load(),
                     "detail": ", ".join(f"{k} {v[0]:.2f} s" for k, v in t.items() if k != "total")
                               + f"; CPU {cpu:.2f} s; median of {runs} runs ({totals[0]:.2f}-{totals[-1]:.2f} s)"})
        rows.append({"case": f"study {name} SDP outer (N={N}, p={p})",
                     "method": "S-procedure, column generation over every tightened strip",
                     "time_s": t["SDP outer"][0], "reference": "previous: every non-redundant strip, 1 LP/side",
                     "ref_time_s": ref_t, "ratio": ref_t / t["SDP outer"][0], "max_dev": np.nan,
                     "log_vol_per_axis": outer.ellipsoid.log_volume() / p, "load_avg": _load(),
                     "detail": detail + f"ours: {outer.info['rounds']} SDP rounds, {len(outer.strips)} strips in "
                               f"the SDP, {outer.info['strips_tightened']} tightened, {outer.info['support_lps']} "
                               f"support LPs, max reduced cost {outer.info['max_reduced_cost']:.2g}"})
        same = "" if nr is None else f"; same strips as the previous method: {np.array_equal(nr, ours_nr)}"
        rows.append({"case": f"study {name} nonredundant (N={N}, p={p})",
                     "method": "box screen, dual-bound screening, cone/ray certificates",
                     "time_s": t_nr, "reference": "previous: 1 LP per side the LP box reaches",
                     "ref_time_s": ref_nr_t, "ratio": ref_nr_t / t_nr, "max_dev": np.nan,
                     "log_vol_per_axis": np.nan, "load_avg": _load(),
                     "detail": f"{len(ours_nr)} non-redundant strips{same}"})
    return rows


def _large_rows(sizes, p, rng):
    rows = []
    for N in sizes:
        W, y, e = _problem(rng, p, N)
        t0 = time.perf_counter()
        b = Polytope.from_strips(W, y, e).bounds()
        dt = time.perf_counter() - t0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e9  # Linux: ru_maxrss in KiB
        rows.append({"case": f"bounds p={p} N={N:.0e}", "method": "staged constraint generation (highspy)",
                     "time_s": dt, "reference": "", "ref_time_s": np.nan, "ratio": np.nan, "max_dev": np.nan,
                     "log_vol_per_axis": np.nan, "load_avg": _load(), "peak_rss_gb": peak,
                     "detail": f"W alone {W.nbytes / 1e9:.2f} GB; {b.info['passes']} "
                               f"passes, {b.info['lp_solves']} LP solves, {b.info['strips_reaching_box']} strips "
                               "reach the final box"})
        P = Polytope.from_strips(W, y, e)
        t0 = time.perf_counter()
        c = P.consistency()
        dt = time.perf_counter() - t0
        rows.append({"case": f"consistency p={p} N={N:.0e}", "method": "staged minimax LP, level screen (highspy)",
                     "time_s": dt, "reference": "", "ref_time_s": np.nan, "ratio": np.nan, "max_dev": np.nan,
                     "log_vol_per_axis": np.nan, "load_avg": _load(), "peak_rss_gb": np.nan,
                     "detail": f"gamma* = {c.gamma:.9f}, {len(c.active)} rows active"})
        del W, y, e, P
    return rows


def run(quick: bool = False) -> pd.DataFrame:
    """Bounds for N = 1e3, 1e4, 1e5 (quick: 300, 3000) and SDP ellipsoids for m = 50, 200, 1000
    (quick: 50), p = 14, the references in the same run (cvxpy only up to N = 1e4: at N = 1e5 its
    28 solves took 380 s on the 2-core machine, against 160 s for linprog and 0.63 s for ours);
    then the three studies' exact stages (quick, and the UR5: without the previous-method reference) and LP
    bounds at N = 1e6, 1e7 (quick: 1e5)."""
    rng = np.random.default_rng(2024)
    p = 14
    W0 = np.random.default_rng(0).normal(size=(200, p))   # compiled kernels loaded before any timing
    Polytope.from_strips(W0, W0 @ np.ones(p), 1.0).bounds()
    sizes = (300, 3000) if quick else (1_000, 10_000, 100_000)
    rows = _bounds_rows(sizes, p, rng, cvxpy_max_n=10_000)
    rows += _sdp_rows((50,) if quick else (50, 200, 1000), p, rng)
    rows += _study_rows(STUDIES, reference=not quick, runs=1 if quick else STUDY_RUNS)
    rows += _large_rows((100_000,) if quick else (1_000_000, 10_000_000), p, rng)
    for r in rows:
        r.setdefault("load_avg", _load())
    return pd.DataFrame(rows)
