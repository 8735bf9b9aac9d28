"""Batch least squares: ordinary (OLS) and Gautier's weighted least squares (IDIM-WLS).

Both solve y = W theta + e through the thin SVD W = U diag(s) V^T (the same factorisation
``numpy.linalg.lstsq`` uses), which also gives the rank, the condition number and, when W is rank
deficient, the null space naming the parameter combinations the data cannot separate.

Statistics (Gaussian, homoscedastic noise after weighting; [Gautier1997], [GautierKhalil1990]):

- residual variance      sigma^2 = |y - W theta|^2 / (N - p)
- covariance             C = sigma^2 (W^T W)^-1 = sigma^2 V diag(s^-2) V^T
- standard deviations    sigma_j = sqrt(C_jj), relative  %sigma_j = 100 sigma_j / |theta_j|
- intervals              theta_j -+ t_{(1+level)/2, N-p} sigma_j                   (Student t)
- ellipsoid              {x : (x - theta)^T C^-1 (x - theta) <= chi2_{level, p}}   (chi-square, p dof)

These are *statistical* sets (kind="statistical"): they hold the truth with probability ``level``
under the noise model, never with certainty.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg
from scipy import stats

from boundid._validation import as_regression
from boundid.errors import InputError
from boundid.estimators.estimate import Estimate, Statistics
from boundid.estimators.method import Method, Style, option
from boundid.estimators.protocol import check_names
from boundid.sets.ellipsoid import Ellipsoid


class RankDeficientError(InputError):
    """W does not determine every parameter: some combinations lie in its null space.

    Attributes
    ----------
    combinations : list[str]   the unidentifiable combinations, e.g. ``["a - b"]``
    null_space : (k, p)        the same combinations as coefficient rows
    rank : int                 numerical rank of W
    """

    def __init__(self, message: str, combinations: list[str], null_space: np.ndarray, rank: int):
        super().__init__(message)
        self.combinations = combinations
        self.null_space = null_space
        self.rank = rank


def check_level(level: float) -> float:
    """A confidence level strictly between 0 and 1."""
    try:
        lv = float(level)
    except (TypeError, ValueError):
        raise InputError(f"level must be a number in (0, 1), got {level!r}.") from None
    if not 0.0 < lv < 1.0:
        raise InputError(f"level must lie strictly between 0 and 1 (e.g. 0.95), got {level}.")
    return lv


def format_combination(coef: np.ndarray, names: tuple[str, ...]) -> str:
    """``[1, -1, 0]`` with names (a, b, c) -> ``"a - b"``; other coefficients as ``0.5*c``."""
    parts = []
    for c, name in zip(coef, names, strict=True):
        if c == 0.0:
            continue
        mag = abs(c)
        term = name if mag == 1.0 else f"{mag:.6g}*{name}"
        if not parts:
            parts.append(term if c > 0 else f"-{term}")
        else:
            parts.append(f"{'+' if c > 0 else '-'} {term}")
    return " ".join(parts)


def null_combinations(null_rows: np.ndarray, names: tuple[str, ...]) -> tuple[np.ndarray, list[str]]:
    """Readable basis of a null space given as orthonormal rows (k, p).

    The basis is brought to reduced form on k pivot parameters chosen by QR with column pivoting
    (coefficient 1 on the pivot, 0 on the other pivots), coefficients below 1e-9 are zeroed and
    each row's first nonzero coefficient is made positive. Returns (rows, strings).
    """
    k = null_rows.shape[0]
    _, _, piv = scipy.linalg.qr(null_rows, pivoting=True)
    B = np.linalg.solve(null_rows[:, piv[:k]], null_rows)
    B[np.abs(B) < 1e-9] = 0.0
    B = np.round(B, 9)
    for i in range(k):
        first = B[i][np.nonzero(B[i])[0][0]]
        B[i] *= np.sign(first)
    return B, [format_combination(row, names) for row in B]


def _names_or_default(names: tuple[str, ...] | None, p: int) -> tuple[str, ...]:
    return names if names is not None else tuple(f"theta{j + 1}" for j in range(p))


def _svd_solve(W: np.ndarray, y: np.ndarray, names: tuple[str, ...] | None, what: str):
    """theta, (W^T W)^-1, singular values; raises RankDeficientError naming the null space."""
    U, s, Vt = np.linalg.svd(W, full_matrices=False)
    N, p = W.shape
    tol = s[0] * max(N, p) * np.finfo(float).eps  # numpy.linalg.matrix_rank's default
    rank = int(np.sum(s > tol))
    if rank < p:
        B, combos = null_combinations(Vt[rank:], _names_or_default(names, p))  # N > p: Vt is p x p
        raise RankDeficientError(
            f"{what} is rank deficient: rank {rank} < {p} parameters (smallest singular value "
            f"{s[-1]:.3g}, tolerance {tol:.3g}). These parameter combinations leave W theta unchanged and "
            f"cannot be identified: {'; '.join(combos)}. Regroup them into base parameters (keep one "
            "parameter of each combination) or use an excitation that separates them.",
            combos,
            B,
            rank,
        )
    theta = Vt.T @ ((U.T @ y) / s)
    inv_info = (Vt.T / s**2) @ Vt
    return theta, 0.5 * (inv_info + inv_info.T), s


def _statistical_estimate(method, theta, cov, s, dof, sigma, level, names, n_samples, t0, extra) -> Estimate:
    p = theta.shape[0]
    std = np.sqrt(np.diag(cov))
    with np.errstate(divide="ignore"):
        rel = 100.0 * std / np.abs(theta)
    tq = stats.t.ppf(0.5 * (1.0 + level), dof)
    chi2 = stats.chi2.ppf(level, p)
    try:
        ell = Ellipsoid(theta, chi2 * cov)
    except InputError:
        raise RankDeficientError(
            f"{method}: the covariance is numerically singular (cond(W) = {s[0] / s[-1]:.3g}); the parameters "
            "are not separately identifiable at double precision. Regroup parameters or improve the excitation.",
            [],
            np.zeros((0, p)),
            p,
        ) from None
    statistics = Statistics(cov=cov, std_err=std, rel_std_pct=rel, dof=int(dof), sigma=sigma,
                            condition_number=float(s[0] / s[-1]), noise_variance=sigma**2)
    return Estimate(
        method=method,
        center=theta,
        set=ell,
        intervals=(theta - tq * std, theta + tq * std),
        kind="statistical",
        level=level,
        names=names,
        n_samples=int(n_samples),
        time_s=time.perf_counter() - t0,
        statistics=statistics,
        info=extra,
    )


def _check_dof(N: int, p: int, what: str) -> int:
    if N <= p:
        raise InputError(
            f"{what} has {N} rows for {p} parameters; the noise variance needs N > p "
            "(at least one residual degree of freedom). Add samples."
        )
    return N - p


def ols(W, y, level: float = 0.95, names=None) -> Estimate:
    """Ordinary least squares with Student-t intervals and a chi-square confidence ellipsoid.

    Parameters
    ----------
    W : (N, p)    observation matrix
    y : (N,)      measurements (units of y)
    level : float confidence level of the intervals and of the ellipsoid, in (0, 1)
    names : p parameter names (used in the report and in the rank-deficiency message)

    Returns an :class:`Estimate` with kind="statistical", n_samples, time_s and ``statistics``:
    dof = N - p, sigma (residual standard deviation, units of y; the noise variance is sigma^2),
    std_err (p,), rel_std_pct (p,), cov (p, p), condition_number of W; ``info["rss"]``.
    Raises :class:`RankDeficientError` (an InputError) when W has rank < p.
    """
    t0 = time.perf_counter()
    W, y = as_regression(W, y)
    N, p = W.shape
    level = check_level(level)
    names = check_names(names, p)
    dof = _check_dof(N, p, "W")
    theta, inv_info, s = _svd_solve(W, y, names, "W")
    r = y - W @ theta
    rss = float(r @ r)
    sigma2 = rss / dof
    return _statistical_estimate("OLS", theta, sigma2 * inv_info, s, dof, float(np.sqrt(sigma2)), level, names, N, t0,
                                 {"rss": rss})


def wls(W, y, groups, level: float = 0.95, names=None) -> Estimate:
    """Weighted least squares with per-group noise levels (Gautier's IDIM-WLS).

    1. The full W must have rank p (else :class:`RankDeficientError`).
    2. For each group j (rows R_j, N_j = |R_j|, typically one joint), Gautier's per-joint estimate
       from the OLS residuals of that group's own subsystem y_j = W_j theta:
           sigma_j^2 = |y_j - W_j theta_j|^2 / (N_j - c_j),   theta_j = lstsq(W_j, y_j),
       with c_j = rank(W_j) (= p unless the joint's rows leave some parameters out). This is
       unbiased for each group whatever the other groups' noise. Needs N_j > c_j.
    3. Scale each row of group j by 1/sigma_j and solve OLS on the scaled problem
       (W_s, y_s); covariance, intervals and ellipsoid are those of that OLS
       (its residual variance, ~1 when the groups' noise levels are right).

    Parameters
    ----------
    W : (N, p), y : (N,)   the regression
    groups : (N,)          group label of each row, e.g. ``Regression.joint``
    level, names           as in :func:`ols`

    ``statistics.noise_variance`` is {label: sigma_j^2} (units of y squared), the noise of each
    group's rows; its condition_number is that of the weighted W and sigma the residual standard
    deviation of the weighted problem (dimensionless, ~1). ``info`` adds sigma_groups
    {label: sigma_j} (units of y), groups (labels, sorted) and sigma_group_values (in that order).
    """
    t0 = time.perf_counter()
    W, y = as_regression(W, y)
    N, p = W.shape
    level = check_level(level)
    names = check_names(names, p)
    g = np.asarray(groups)
    if g.shape != (N,):
        raise InputError(f"groups must have shape ({N},) (one label per row of W), got {g.shape}.")
    if g.dtype.kind == "f" and not np.all(np.isfinite(g)):
        raise InputError("groups contains NaN or infinite labels; give every row an integer group (joint) label.")
    _check_dof(N, p, "W")
    _svd_solve(W, y, names, "W")  # rank check of the whole regression, naming lost combinations
    labels, inverse = np.unique(g, return_inverse=True)
    sig = np.empty(labels.size)
    for j in range(labels.size):
        rows = inverse == j
        theta_j, _, c_j, _ = np.linalg.lstsq(W[rows], y[rows])
        n_j = int(rows.sum())
        if n_j <= c_j:
            raise InputError(
                f"group {labels[j].item()!r} has {n_j} rows for rank(W_j) = {c_j}; sigma_j^2 = "
                f"|r_j|^2 / (N_j - rank W_j) needs N_j > rank W_j. Merge small groups or use ols()."
            )
        r = y[rows] - W[rows] @ theta_j
        if np.linalg.norm(r) <= 1e-12 * np.linalg.norm(y[rows]):
            raise InputError(
                f"group {labels[j].item()!r} is fitted exactly (residuals at rounding level), so its weight "
                "1/sigma_j is infinite. The data look noise-free: use ols() or a set-membership estimator."
            )
        sig[j] = np.sqrt(r @ r / (n_j - c_j))
    row_w = 1.0 / sig[inverse]
    Ws, ys = W * row_w[:, None], y * row_w
    est = ols(Ws, ys, level=level, names=names)
    sigma_groups = {lab.item(): float(s) for lab, s in zip(labels, sig, strict=True)}
    est.method = "WLS"
    est.time_s = time.perf_counter() - t0
    est.statistics = replace(est.statistics, noise_variance={g: s**2 for g, s in sigma_groups.items()})
    est.info.update({"sigma_groups": sigma_groups, "groups": labels, "sigma_group_values": sig})
    return est


# ------------------------------------------------------------------------------ registry entries


@dataclass(frozen=True)
class LevelOptions:
    """What a study file may set for ``method = "ols"`` or ``"wls"``."""

    level: float = option(0.95, "confidence level of the intervals and the ellipsoid", lo=0.0, strict_lo=True,
                          hi=1.0, strict_hi=True)


OLS_METHOD = Method(name="ols", summary="ordinary least squares with Student-t intervals",
                    options=LevelOptions, build=lambda pb, o: ols(pb.W, pb.y, level=o.level, names=pb.names),
                    set_family="ellipsoid", kind="statistical", needs_bound=False, style=Style("#E69F00", "P", "-"))
WLS_METHOD = Method(name="wls", summary="IDIM-WLS: rows weighted by each joint's residual standard deviation",
                    options=LevelOptions,
                    build=lambda pb, o: wls(pb.W, pb.y, pb.groups, level=o.level, names=pb.names),
                    set_family="ellipsoid", kind="statistical", needs_bound=False, style=Style("#D55E00", "X", "-"))
