"""`Estimate`: what every estimator returns, set-membership and statistical alike.

Because every estimator returns one, every comparison (interval widths, volumes, distance to
truth, containment of the truth) is written once, in the studies and report layers, against the
:class:`~boundid.sets.ConvexSet` protocol of ``Estimate.set``. What another layer reads is a typed
field here; ``info`` holds free-form extras that only a reader of one estimator looks at.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd

from boundid.sets.convex import ConvexSet

# "unverified": a set-membership estimator's set that the estimator cannot vouch for (rounding may
# have moved it off the truth); ``unverified_reason`` says why. Only "guaranteed" is guaranteed.
Kind = Literal["guaranteed", "unverified", "statistical", "point"]


@dataclass(frozen=True)
class History:
    """Trace of a recursive estimator: after every ``record_every`` samples, or (the OBE default)
    after every update step, the only rows where a set-membership estimate changes.

    index : (K,) int       sample index (0-based, the row of W just processed)
    centers : (K, p)       estimate after that sample
    log_volumes : (K,)     ln vol of the set after that sample (NaN where the family cannot say)
    shapes : (K, p, p)     ellipsoid shape matrices, only when asked for (teaching pictures)
    """

    index: np.ndarray
    centers: np.ndarray
    log_volumes: np.ndarray
    shapes: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.index.shape[0])


@dataclass(frozen=True)
class Statistics:
    """What a statistical estimate knows about its noise (Gaussian, white, independent of the
    regressors).

    cov : (p, p)             covariance of the centre (parameter units squared)
    std_err : (p,)           standard errors sqrt(diag cov)
    rel_std_pct : (p,)       100 std_err / |center| [%]
    dof : float              residual degrees of freedom (inf when the noise variance is given: Kalman)
    sigma : float            residual standard deviation of the fit (units of y; WLS: of the
                             weighted problem, dimensionless, ~1); NaN where not estimated
    condition_number : float cond(W) (WLS: of the weighted W; the filters: sqrt(cond P))
    noise_variance : float or {group: float}
                             variance of one row's measurement noise (units of y squared), for
                             prediction bands: the residual variance (OLS, RLS), R (Kalman), or
                             one per group of rows (WLS: per joint)
    """

    cov: np.ndarray
    std_err: np.ndarray
    rel_std_pct: np.ndarray
    dof: float
    sigma: float
    condition_number: float
    noise_variance: float | Mapping

    def row_noise_variance(self, groups: np.ndarray) -> np.ndarray | float:
        """The noise variance of each row (N,) given its group label (``Regression.joint``)."""
        if isinstance(self.noise_variance, Mapping):
            return np.asarray([self.noise_variance[g] for g in np.asarray(groups).tolist()])
        return float(self.noise_variance)


@dataclass
class Estimate:
    """The result of an estimator.

    method : str               e.g. "OBE-factorized (volume)", "WLS", "RLS"
    center : (p,)              the point estimate (set centre, LS solution)
    set : ConvexSet | None     the guaranteed set (``kind="guaranteed"``), the set a guaranteed
                               estimator could not vouch for (``kind="unverified"``), or the
                               confidence set at ``level`` (``kind="statistical"``); None if none
    intervals : (lo, hi)       per-parameter bounds, each (p,)
    kind : "guaranteed" | "unverified" | "statistical" | "point"
    level : float | None       confidence level of statistical sets (e.g. 0.95)
    names : tuple[str] | None  parameter names, from the model
    history : History | None   per-sample trace of recursive estimators
    outliers : (k,) int        indices of rows that contradicted the bounds (skipped)
    outlier_residuals : (k,)   their innovations y - w^T c at the time they were met
    n_samples : int            rows processed
    n_updates : int            rows that changed a set-membership estimate (0 for statistical ones)
    n_skipped : int            rows whose strip held the whole set (no information)
    time_s : float             time spent in the estimator [s] (NaN if not measured)
    statistics : Statistics | None   the noise model of a statistical estimate
    error_bound : float        guaranteed recursions: first-order bound on the rounding error of
                               the Mahalanobis^2 (or gauge) of a point of the set (0 if exact)
    inflation : float          relative enlargement of the reported set that absorbs it
    unverified_reason : str | None   why a set is "unverified" (None otherwise)
    info : dict                free-form extras of one estimator (criterion, solver counts ...)
    """

    method: str
    center: np.ndarray
    set: ConvexSet | None
    intervals: tuple[np.ndarray, np.ndarray]
    kind: Kind
    level: float | None = None
    names: tuple[str, ...] | None = None
    history: History | None = None
    outliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    outlier_residuals: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n_samples: int = 0
    n_updates: int = 0
    n_skipped: int = 0
    time_s: float = float("nan")
    statistics: Statistics | None = None
    error_bound: float = 0.0
    inflation: float = 0.0
    unverified_reason: str | None = None
    info: dict = field(default_factory=dict)

    @property
    def p(self) -> int:
        return int(self.center.shape[0])

    @property
    def guaranteed(self) -> bool:
        return self.kind == "guaranteed"

    @property
    def set_membership(self) -> bool:
        """A set-membership estimate: guaranteed, or a guaranteed method's set it could not vouch for."""
        return self.kind in ("guaranteed", "unverified")

    @property
    def n_outliers(self) -> int:
        return int(self.outliers.size)

    def parameter_names(self) -> tuple[str, ...]:
        return self.names if self.names is not None else tuple(f"theta{j + 1}" for j in range(self.p))

    def contains(self, theta) -> bool:
        """Whether ``theta`` lies in the estimate's set (False if it has none)."""
        return bool(self.set is not None and self.set.contains(np.asarray(theta, float)))

    def to_frame(self) -> pd.DataFrame:
        """One row per parameter: center, lo, hi, width (and std error where known)."""
        lo, hi = self.intervals
        df = pd.DataFrame(
            {"center": self.center, "lo": lo, "hi": hi, "width": hi - lo},
            index=pd.Index(self.parameter_names(), name="parameter"),
        )
        if self.statistics is not None:
            df.insert(1, "std_err", np.asarray(self.statistics.std_err))
        return df

    def summary(self) -> str:
        """A plain-text table in the manner of statsmodels' ``summary()``."""
        set_name = {
            "guaranteed": "guaranteed set (contains every parameter consistent with the bounds)",
            "unverified": "UNVERIFIED set (the estimator cannot vouch that it contains the truth)",
            "statistical": f"confidence set at level {self.level}",
            "point": "point estimate (no set)",
        }[self.kind]
        head = [
            ("Method", self.method),
            ("Set", set_name),
            ("Parameters", str(self.p)),
            ("Samples", str(self.n_samples)),
        ]
        if self.set_membership:
            head.append(("Updates", str(self.n_updates)))
        if self.statistics is not None:
            head.append(("cond(W)", f"{self.statistics.condition_number:.4g}"))
        if np.isfinite(self.time_s):
            head.append(("Time [s]", f"{self.time_s:.4g}"))
        if self.kind == "unverified":
            head.append(("Why", self.unverified_reason or "not given"))
        if self.set_membership or self.outliers.size:
            head.append(("Outliers", str(self.outliers.size)))
        if self.set is not None:
            head.append(("ln volume", f"{self.set.log_volume():.6g}"))
        width = 78
        lines = ["=" * width, f"{'boundid estimate':^{width}}", "-" * width]
        for k, v in head:  # long values (the reason of an unverified set) wrap under themselves
            lines += textwrap.wrap(f"{k + ':':<14}{v}", width, subsequent_indent=" " * 14) or [""]
        lines.append("-" * width)
        table = self.to_frame().to_string(float_format=lambda v: f"{v: .6g}")
        lines += table.splitlines()
        lines.append("=" * width)
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()
