"""Benchmark of the recursive set families against plain numpy loops and the batch LP."""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from boundid.estimators import (
    OBE,
    BoxedOBE,
    BoxRecursion,
    LimitedPolytopeRecursion,
    ParallelotopeRecursion,
    PolytopeRecursion,
    WindowedOBE,
    ZonotopeRecursion,
)
from boundid.estimators.box_recursion import box_step
from boundid.estimators.parallelotope_recursion import parallelotope_step
from boundid.estimators.zonotope_recursion import zonotope_step
from boundid.sets import Box, Polytope

GOALS = """
Recursive guaranteed-set families on random strips: rows w ~ N(0, I), uniform
errors within e = 0.5, truth ~ N(0, I), prior box 0 +- 10 (every family starts from it; the
OBE from the ellipsoid circumscribing it).

* **Compiled families** (box, parallelotope, zonotope with at most 2p generators): samples/s of
  the numba loop over N rows (best of 3 unless a run takes over 10 s, wall clock; `cpu` =
  process CPU time, the machine's two cores are shared) against a plain Python loop calling the family's numpy step
  (`box_step`, `parallelotope_step`, `zonotope_step`) on the last `n_ref` rows, started from
  the compiled run's set there; `ratio` = compiled / numpy rate. The OBE (factorized, volume)
  is timed on the same data for reference.
* **Quality**: `width_over_lp` = mean over parameters of the family's interval width over the
  exact LP width (batch `Polytope.bounds` on all N rows and the prior box); `contains_truth`.
* **Polytope recursions against batch LP on the same data**: the exact recursion
  (double description, p <= 4) and the limited-complexity polytope (K = 4p strips, LP every
  100p samples) report samples/s and their time against `batch_lp_s`, the time of the exact
  LP bounds of all rows at once (HiGHS, constraint generation). The OBE variants are timed the
  same way. The windowed OBE (one SDP per window of 20p samples) runs on the first 4000 rows
  only; its `width_over_lp` is against the LP of those rows, next to the OBE on the same rows.
* `stored` = numbers the estimator keeps between samples.
"""


def _problem(p, N, seed):
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    e = np.full(N, 0.5)
    return theta, W, W @ theta + rng.uniform(-0.5, 0.5, N), e


def _best_of(make, W, y, e, repeats=3):
    """Best wall and CPU time of ``repeats`` fits (one only when a fit takes over 10 s)."""
    wall = cpu = np.inf
    for _ in range(repeats):
        if wall > 10.0 and wall < np.inf:
            break
        est = make()
        t0, c0 = time.perf_counter(), time.process_time()
        res = est.fit(W, y, e)
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    return res, wall, cpu


def _numpy_loop(family, S, W, y, e, p):
    """The family's numpy step over rows W, from set S; returns wall time."""
    t0 = time.perf_counter()
    if family == "box":
        lo, hi = S.intervals()
        for k in range(W.shape[0]):
            _, lo, hi = box_step(lo, hi, W[k], y[k], e[k])
    elif family == "parallelotope":
        c, G = S.center, S.generators
        for k in range(W.shape[0]):
            _, c, G, _ = parallelotope_step(c, G, W[k], y[k], e[k])
    else:
        c, G = S.center, S.generators
        for k in range(W.shape[0]):
            _, c, G, _ = zonotope_step(c, G, W[k], y[k], e[k], 2 * p)
    return time.perf_counter() - t0


def _prior(p: int) -> Box:
    """The prior box 0 +- 10 every family starts from."""
    return Box.from_center(np.zeros(p), 10.0)


COMPILED = {
    "box": (lambda p: BoxRecursion(p, prior=_prior(p), record_every=10**9), lambda p: 2 * p),
    "parallelotope": (lambda p: ParallelotopeRecursion(p, prior=_prior(p), record_every=10**9),
                      lambda p: p * p + p),
    "zonotope": (lambda p: ZonotopeRecursion(p, prior=_prior(p), record_every=10**9),
                 lambda p: (2 * p + 1) * p + p),
}


def _row(family, p, N, est, wall, cpu, b, theta, stored, **extra):
    lo, hi = est.intervals
    return {"family": family, "p": p, "N": N, "n_updates": est.n_updates,
            "samples_per_s": N / wall, "cpu_samples_per_s": N / max(cpu, 1e-9),
            "width_over_lp": float(np.mean((hi - lo) / (b.hi - b.lo))), "contains_truth": est.contains(theta),
            "stored": stored, **extra}


def run(quick: bool = False) -> pd.DataFrame:
    rows = []
    for p in (9, 14, 40):
        N = 10_000 if quick else 100_000
        n_ref = 300 if quick else 2_000
        theta, W, y, e = _problem(p, N, p)
        box = (-10 * np.ones(p), 10 * np.ones(p))
        t0 = time.perf_counter()
        b = Polytope(W, y, e, box=box).bounds()
        batch_lp = time.perf_counter() - t0
        for family, (make, stored) in COMPILED.items():
            make(p).fit(W[:50], y[:50], e[:50])  # compile / load the cache
            est, wall, cpu = _best_of(lambda m=make, p=p: m(p), W, y, e)
            head = make(p).fit(W[: N - n_ref], y[: N - n_ref], e[: N - n_ref])
            t_ref = _numpy_loop(family, head.set, W[N - n_ref:], y[N - n_ref:], e[N - n_ref:], p)
            rows.append(_row(family, p, N, est, wall, cpu, b, theta, stored(p), numpy_samples_per_s=n_ref / t_ref,
                             ratio=(N / wall) / (n_ref / t_ref), batch_lp_s=batch_lp))
        est, wall, cpu = _best_of(lambda p=p: OBE(p, prior=_prior(p), record_every=10**9), W, y, e)
        rows.append(_row("OBE (reference)", p, N, est, wall, cpu, b, theta, p * p + p, batch_lp_s=batch_lp))
        est, wall, cpu = _best_of(lambda p=p: BoxedOBE(p, prior=_prior(p), record_every=10**9), W, y, e, 1)
        rows.append(_row("OBE ∩ prior box", p, N, est, wall, cpu, b, theta, p * p + p, batch_lp_s=batch_lp))
        est, wall, cpu = _best_of(lambda p=p: LimitedPolytopeRecursion(p, prior=_prior(p)), W, y, e, 1)
        rows.append(_row("limited polytope", p, N, est, wall, cpu, b, theta, 4 * p * (p + 2) + 2 * p,
                         batch_lp_s=batch_lp, time_over_batch_lp=wall / batch_lp))
        if p <= 14:
            Nw = 1_000 if quick else 4_000
            bw = Polytope(W[:Nw], y[:Nw], e[:Nw], box=box).bounds()
            est, wall, cpu = _best_of(lambda p=p: WindowedOBE(p, prior=_prior(p)), W[:Nw], y[:Nw], e[:Nw], 1)
            rows.append(_row("windowed OBE", p, Nw, est, wall, cpu, bw, theta, p * p + p,
                             n_resets=est.info["n_resets"]))
            est, wall, cpu = _best_of(lambda p=p: OBE(p, prior=_prior(p), record_every=10**9),
                                      W[:Nw], y[:Nw], e[:Nw])
            rows.append(_row("OBE (reference)", p, Nw, est, wall, cpu, bw, theta, p * p + p))
    for p in (2, 3, 4):
        N = 2_000 if quick else 20_000
        theta, W, y, e = _problem(p, N, 100 + p)
        box = (-10 * np.ones(p), 10 * np.ones(p))
        t0 = time.perf_counter()
        b = Polytope(W, y, e, box=box).bounds()
        batch_lp = time.perf_counter() - t0
        est, wall, cpu = _best_of(lambda p=p, N=N: PolytopeRecursion(p, prior=_prior(p), record_every=N), W, y, e, 1)
        dev = max(np.abs(est.intervals[0] - b.lo).max(), np.abs(est.intervals[1] - b.hi).max())
        rows.append(_row("exact polytope", p, N, est, wall, cpu, b, theta,
                         est.info["n_vertices"] * p + est.info["n_facets"] * (p + 1), batch_lp_s=batch_lp,
                         time_over_batch_lp=wall / batch_lp, max_dev_from_lp=dev))
    return pd.DataFrame(rows)

