"""Statistical estimators: compiled RLS / Kalman loops against a numpy loop and filterpy."""

from __future__ import annotations

import os
import time

import numpy as np
import pandas as pd

from boundid.bench.goals import Goal
from boundid.estimators import RLS, KalmanEstimator, ols

GOALS = """
RLS and the Kalman estimator (p = 14 parameters, N = 100 000 regression rows, Gaussian data).

- Goal: the compiled RLS loop (`RLS.fit`) runs >= 5 M updates/s (prototype: 7.2 M/s).
- References, run on fewer rows and scaled linearly to N: `RLS.update` row by row (a numpy loop)
  and `filterpy.kalman.KalmanFilter` (~34 k updates/s on the prototype machine).
- `ratio` = time for N rows / time of the compiled RLS without history; `max_abs_diff` = largest
  |theta - theta_numba| against the compiled loop of the same filter on the same rows.
- Compiled cases: best of 3 runs after a warm-up (no compilation in the timings); loops: one run.
- Absolute rates depend on the machine's load (shared cores halve them; `load_avg` is the 1-minute
  load average when each case started); the ratio to filterpy does not much (prototype: 7.2 M/s /
  34 k/s = 212x).
"""

GOAL_CHECKS = (
    Goal("compiled RLS loop: rate", {"case": r"RLS numba \(no history\)"}, "updates_per_s", ">=", 5.0,
         "M updates/s", size="p = {p}, N = {rows_run:,}", scale=1e-6),
)


def _timed(fn, repeats: int):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def run(quick: bool = False) -> pd.DataFrame:
    p = 14
    N = 10_000 if quick else 100_000
    n_small = 500 if quick else 2_000
    rng = np.random.default_rng(0)
    W = rng.normal(size=(N, p))
    y = W @ rng.normal(size=p) + 0.1 * rng.normal(size=N)
    RLS(p).fit(W[:50], y[:50])  # warm-up: load the compiled loop
    KalmanEstimator(p, shape0=1000.0, R=1.0).fit(W[:50], y[:50])

    def rls_numba(rows, record_every=0):
        return RLS(p, record_every=record_every).fit(W[:rows], y[:rows]).center

    def rls_numpy(rows):
        r = RLS(p, record_every=0)
        for k in range(rows):
            r.update(W[k], y[k])
        return r.theta

    def kalman(rows, engine):
        return KalmanEstimator(p, shape0=1000.0, R=0.01, record_every=0).fit(W[:rows], y[:rows], engine=engine).center

    cases = [
        ("RLS numba (no history)", N, 3, lambda: rls_numba(N), lambda: rls_numba(N)),
        ("RLS numba (history every row)", N, 3, lambda: rls_numba(N, 1), lambda: rls_numba(N)),
        ("RLS numpy loop (update)", n_small, 1, lambda: rls_numpy(n_small), lambda: rls_numba(n_small)),
        ("Kalman numba", N, 3, lambda: kalman(N, "numba"), lambda: kalman(N, "numba")),
        ("Kalman filterpy", n_small, 1, lambda: kalman(n_small, "filterpy"), lambda: kalman(n_small, "numba")),
        ("OLS batch (SVD)", N, 3, lambda: ols(W, y).center, lambda: rls_numba(N)),
    ]
    rows = []
    for name, n_rows, repeats, fn, ref in cases:
        load = os.getloadavg()[0]
        t, theta = _timed(fn, repeats)
        rows.append(
            {
                "case": name,
                "rows_run": n_rows,
                "time_s": t,
                "time_for_N_s": t * N / n_rows,
                "updates_per_s": n_rows / t,
                "max_abs_diff": float(np.max(np.abs(theta - ref()))),
                "load_avg": load,
            }
        )
    df = pd.DataFrame(rows)
    df["ratio"] = df["time_for_N_s"] / df.loc[0, "time_for_N_s"]
    df["p"] = p
    return df
