"""What every recursive guaranteed-set estimator shares: the prior box, the fit / partial_fit /
update protocol (:mod:`boundid.estimators.protocol`), outliers, the history, and the
:class:`Estimate` it returns.

Model: y_k = w_k^T theta + e_k, |e_k| <= e_max_k. Each family keeps an outer set X_k with
X_k ⊇ X_{k-1} ∩ S_k, S_k = {theta : |y_k - w_k^T theta| <= e_max_k}, starting from a prior box
that must contain the true theta. Then theta stays in every X_k. A strip that misses X_{k-1}
contradicts the bounds: an outlier, recorded and skipped (``on_outlier="skip"``) or raised.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from boundid._validation import as_bounds, as_regression
from boundid.errors import InfeasibleDataError, InputError
from boundid.estimators._set_kernels import KAPPA, NO_INFO, OUTLIER, ROUND_GUARD, UPDATE
from boundid.estimators.estimate import Estimate, History
from boundid.estimators.protocol import RecursiveEstimator, box_prior

#: shape0 when no prior is given: the ball of radius 1000 about center0, whose bounding box is
#: center0 +- 1000
DEFAULT_SHAPE0 = 1e6


def clip_strip(y: float, s: float, m: float, r: float, wc: float) -> tuple[int, float, float]:
    """Plain-Python statement of the guard and clipping every step starts with
    (``_set_kernels.clip_strip``): returns (status, yc, sc), status OUTLIER / NO_INFO / UPDATE."""
    g = ROUND_GUARD * (abs(y) + s + wc + r)
    s = s + g
    eps = y - m
    if abs(eps) > s + r:
        return OUTLIER, 0.0, 0.0
    if abs(eps) + r <= s:
        return NO_INFO, 0.0, 0.0
    lo, hi = max(y - s, m - r - g), min(y + s, m + r + g)
    return UPDATE, 0.5 * (lo + hi), max(0.5 * (hi - lo), KAPPA * max(r, s))


@dataclass
class Run:
    """What one pass over a batch of rows produced (indices are global sample indices)."""

    processed: int
    n_updates: int
    n_skipped: int
    hist_idx: np.ndarray
    hist_c: np.ndarray
    hist_lv: np.ndarray
    out_idx: np.ndarray
    out_res: np.ndarray


class SetRecursion(RecursiveEstimator):
    """Base class of the recursive set estimators (not used directly).

    Parameters
    ----------
    p : int
        Number of parameters.
    prior : Box (or any ConvexSet, taken as its interval hull), optional
        The prior box (a-priori parameter values +- ranges, parameter units). The guarantee needs
        the true parameters inside it.
    center0, shape0 : the prior's ellipsoidal spelling (:mod:`boundid.estimators.protocol`): the
        box center0 +- sqrt(diag shape0); default 0 +- 1000.
    on_outlier : "skip" | "raise"
        What to do with a strip that misses the current set.
    record_every : int
        Record the centre and ln volume every ``record_every`` samples (and after the last one).
    names : sequence of str, optional
        Parameter names for the Estimate.
    """

    #: the Estimate's ``method``; subclasses set it
    method = ""

    def __init__(self, p: int, *, prior=None, center0=None, shape0=None, on_outlier: str = "skip",
                 record_every: int = 1, names=None):
        super().__init__(p, names)
        if on_outlier not in ("skip", "raise"):
            raise InputError(f"on_outlier must be 'skip' or 'raise', got {on_outlier!r}.")
        if not (isinstance(record_every, int | np.integer) and record_every >= 1):
            raise InputError(f"record_every must be an integer >= 1, got {record_every!r}.")
        self.prior = box_prior(self.p, prior, center0, shape0, DEFAULT_SHAPE0)
        self.on_outlier, self.record_every = on_outlier, int(record_every)
        self.reset()

    # ------------------------------------------------------------------ protocol
    def reset(self) -> None:
        """Forget every sample: back to the prior box."""
        self.n_samples = self.n_updates = self.n_skipped = 0
        self.time_s = 0.0
        self.unverified_reason: str | None = None
        self._runs: list[Run] = []
        self._start()

    def partial_fit(self, W, y, e_max) -> Estimate:
        """Continue from the current set with the rows of W (N, p), y (N,) with bounds e_max
        (scalar or (N,)). Returns :meth:`estimate`."""
        W, y = as_regression(W, y)
        if W.shape[1] != self.p:
            raise InputError(f"W must have {self.p} columns (one per parameter), got {W.shape[1]}.")
        e = as_bounds(e_max, W.shape[0])
        t0 = time.perf_counter()
        run = self._run(np.ascontiguousarray(W), y, e, self.n_samples)
        self.time_s += time.perf_counter() - t0
        N = W.shape[0]
        self.n_samples += run.processed + (1 if run.processed < N else 0)
        self.n_updates += run.n_updates
        self.n_skipped += run.n_skipped
        self._runs.append(run)
        if run.processed < N:
            raise InfeasibleDataError(
                f"observation {int(run.out_idx[-1])} contradicts the bounds: its strip misses the current "
                f"{self.method} set (innovation {run.out_res[-1]:.6g}, bound {e[run.processed]:.6g}). The data are "
                "inconsistent with e_max (raise the bounds) or that sample is an outlier (use on_outlier='skip').")
        return self.estimate()

    def estimate(self) -> Estimate:
        """The current guaranteed set as an :class:`Estimate` (kind "guaranteed"; "unverified" with
        the reason when a step could not vouch for its set)."""
        S = self.current_set()
        runs = self._runs
        history = History(
            index=np.concatenate([r.hist_idx for r in runs]) if runs else np.zeros(0, np.int64),
            centers=np.concatenate([r.hist_c for r in runs]) if runs else np.zeros((0, self.p)),
            log_volumes=np.concatenate([r.hist_lv for r in runs]) if runs else np.zeros(0),
        )
        outliers = np.concatenate([r.out_idx for r in runs]) if runs else np.zeros(0, np.int64)
        residuals = np.concatenate([r.out_res for r in runs]) if runs else np.zeros(0)
        return Estimate(method=self.method, center=self._center(S), set=S, intervals=self._intervals(S),
                        kind="guaranteed" if self.unverified_reason is None else "unverified", names=self.names,
                        history=history, outliers=outliers, outlier_residuals=residuals, n_samples=self.n_samples,
                        n_updates=self.n_updates, n_skipped=self.n_skipped, time_s=self.time_s,
                        unverified_reason=self.unverified_reason, info=self._info())

    # ------------------------------------------------------------------ per family
    def _start(self) -> None:
        """Set the state to the prior box."""
        raise NotImplementedError

    def _run(self, W: np.ndarray, y: np.ndarray, e: np.ndarray, k0: int) -> Run:
        """Process rows (global indices k0, k0 + 1, ...) in place."""
        raise NotImplementedError

    def current_set(self):
        """The current set (a ConvexSet)."""
        raise NotImplementedError

    def _intervals(self, S) -> tuple[np.ndarray, np.ndarray]:
        return S.intervals()

    def _center(self, S) -> np.ndarray:
        lo, hi = self._intervals(S)
        return 0.5 * (lo + hi)

    def _info(self) -> dict:
        return {}

    # ------------------------------------------------------------------ helpers
    def _buffers(self, N: int) -> dict:
        n_rec = N // self.record_every + 2
        return {"hist_idx": np.empty(n_rec, np.int64), "hist_c": np.empty((n_rec, self.p)),
                "hist_lv": np.empty(n_rec), "out_idx": np.empty(N, np.int64), "out_res": np.empty(N),
                "counts": np.zeros(5, np.int64)}

    def _collect(self, b: dict) -> Run:
        processed, n_upd, n_skip, n_out, n_rec = (int(v) for v in b["counts"])
        return Run(processed, n_upd, n_skip, b["hist_idx"][:n_rec].copy(), b["hist_c"][:n_rec].copy(),
                   b["hist_lv"][:n_rec].copy(), b["out_idx"][:n_out].copy(), b["out_res"][:n_out].copy())

    @property
    def _stop(self) -> bool:
        return self.on_outlier == "raise"


def fit_problem(cls: type[SetRecursion], problem, **options):
    """``cls`` from the problem's prior box, fitted to its rows with its bound e_max (the build
    function of the set families' registry entries, :mod:`boundid.estimators.method`)."""
    est = cls(problem.p, prior=problem.prior, record_every=problem.record_every, names=problem.names, **options)
    return est.fit(problem.W, problem.y, problem.e_max)
