"""Excitation designed for guaranteed identification: trajectories scored by the exact set they leave.

The classical criteria look at W^T W only: the condition number of W (columns scaled to unit norm)
[GautierKhalil1992; Swevers1997] and log det W^T W (D-optimality). For bounded-error data what
matters is the exact feasible set. Its size for a trajectory, before any measurement, is that of
the *design set*

    D(W) = {d : |W d| <= e_max row by row, |d_j| <= r_j}                                     (1)

(r the prior box's half-widths): the exact feasible set, minus the truth, when the errors are zero
and the truth is at the prior's centre. And for any errors within the bound and any truth in the
prior box, the exact set lies in theta_true + 2 D(W): theta feasible gives |W (theta - theta_true)|
<= |y - W theta| + |e| <= 2 e_max, and both lie in the box, so |theta_j - theta_true_j| <= 2 r_j.
So the exact interval of parameter j is at most twice the design width 2 max_{d in D} d_j, whatever
the data: a criterion that guarantees something ([refs §LP]).

The *guaranteed criterion* of a trajectory is the mean over parameters of the design width divided
by the prior width (0: identified exactly, 1: not narrowed beyond the prior box), from the exact LP
bounds of (1) (:meth:`boundid.sets.Polytope.bounds`; D is symmetric, so its width is twice the
upper bound). :func:`search_excitation` scores candidate trajectories by all three criteria at
once, so each criterion's best is picked from the same candidates.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from boundid._validation import as_vector
from boundid.errors import InputError
from boundid.sets import Polytope

#: the criteria, what each measures, and whether a smaller value is better
CRITERIA = {
    "guaranteed": ("mean over parameters of the exact design width / prior width (eq. 1)", True),
    "cond": ("condition number of W with columns scaled to unit norm", True),
    "logdet": ("ln det (W R)^T (W R), R = diag(prior half-widths) (D-optimality)", False),
}


def design_set(W, e_max, half) -> Polytope:
    """The design set (1) of the rows W (N, p) at the bound e_max (one number or (N,) per row; N m,
    or the rows' unit) within the prior half-widths ``half`` (p,): a polytope about 0."""
    W = np.asarray(W, dtype=float)
    half = as_vector(half, "half", W.shape[1])
    if not (np.all(np.isfinite(half)) and np.all(half > 0)):
        raise InputError(f"the prior half-widths must be finite and > 0, got {half}.")
    e = np.asarray(e_max, dtype=float)
    if not (np.all(np.isfinite(e)) and np.all(e > 0)):
        raise InputError(f"e_max must be finite and > 0, got {e_max}.")
    return Polytope(W, np.zeros(W.shape[0]), e, box=(-half, half))


def design_widths(W, e_max, half) -> np.ndarray:
    """Relative design widths (p,): the width of D(W) (1) along each parameter over its prior width
    2 r_j, in [0, 1], by the exact LP bounds."""
    half = np.asarray(half, dtype=float)
    b = design_set(W, e_max, half).bounds()
    return np.clip((b.hi - b.lo) / (2.0 * half), 0.0, 1.0)


def classical_scores(W, half) -> tuple[float, float]:
    """(cond, logdet) of the rows W (N, p): the condition number after scaling each column to unit
    norm, and ln det of (W R)^T (W R), R = diag(half) (unit-free; -inf when rank deficient)."""
    W = np.asarray(W, dtype=float)
    norms = np.linalg.norm(W, axis=0)
    s = np.linalg.svd(W / np.where(norms > 0, norms, 1.0), compute_uv=False)
    cond = float(s[0] / s[-1]) if np.all(norms > 0) and s[-1] > 0 else float("inf")
    sign, logdet = np.linalg.slogdet((W * half).T @ (W * half))
    return cond, float(logdet) if sign > 0 else -np.inf


@dataclass
class ExcitationSearch:
    """Candidates scored by the three criteria.

    candidates : what ``draw`` returned, in draw order; scores : DataFrame indexed by candidate with
    columns guaranteed, cond, logdet, rows (rows of the design regression) and time_s (drawing and
    scoring it); widths : (k, p) relative design widths of each candidate; half : the prior
    half-widths they were scored within; failed : draws that ``draw`` or ``rows`` refused, as
    (draw index, reason).
    """

    candidates: list
    scores: pd.DataFrame
    widths: np.ndarray
    half: np.ndarray
    failed: list[tuple[int, str]]

    def best(self, criterion: str) -> int:
        """Index of the candidate the criterion prefers (ties: the first drawn)."""
        if criterion not in CRITERIA:
            raise InputError(f"unknown excitation criterion {criterion!r}; choose among {', '.join(CRITERIA)}.")
        values = self.scores[criterion].to_numpy()
        return int(np.argmin(values) if CRITERIA[criterion][1] else np.argmax(values))


def search_excitation(draw: Callable[[np.random.Generator], object],
                      rows: Callable[[object], tuple[np.ndarray, np.ndarray]],
                      n_candidates: int, rng: np.random.Generator, half,
                      errors: tuple[type[Exception], ...] = (InputError,)) -> ExcitationSearch:
    """Draw ``n_candidates`` trajectories with ``draw(rng)``, build each one's design regression and
    bound ``rows(candidate)`` -> (W (N, p), e_max (N,)) and score it by every criterion of
    :data:`CRITERIA` within the prior half-widths ``half`` (p,).

    A candidate that ``draw`` or ``rows`` refuses with one of ``errors`` (e.g. a trajectory that no
    scaling keeps within the limits) is recorded in ``failed`` and replaced by the next draw, up to
    ``2 n_candidates`` draws. Deterministic given the state of ``rng``.
    """
    if n_candidates < 1:
        raise InputError(f"the excitation search needs at least 1 candidate, got {n_candidates}.")
    half = np.asarray(half, dtype=float)
    cands, records, widths, failed = [], [], [], []
    for i in range(2 * n_candidates):
        if len(cands) == n_candidates:
            break
        t0 = time.perf_counter()
        try:
            cand = draw(rng)
            W, e = rows(cand)
        except errors as exc:
            failed.append((i, f"{type(exc).__name__}: {exc}"))
            continue
        w = design_widths(W, e, half)
        cond, logdet = classical_scores(W, half)
        cands.append(cand)
        widths.append(w)
        records.append({"guaranteed": float(w.mean()), "cond": cond, "logdet": logdet, "rows": W.shape[0],
                        "time_s": time.perf_counter() - t0})
    if not cands:
        raise InputError(f"no candidate trajectory could be drawn in {2 * n_candidates} tries; the first refusal: "
                         f"{failed[0][1]}")
    scores = pd.DataFrame(records, index=pd.RangeIndex(len(cands), name="candidate"))
    return ExcitationSearch(cands, scores, np.array(widths), half, failed)
