"""`Estimate`: what every estimator returns, set-membership and statistical alike.

Because every estimator returns one, every comparison (interval widths, volumes, distance to
truth, containment of the truth) is written once, in the studies and report layers.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd

from boundid.sets.convex import ConvexSet
from boundid.sets.ellipsoid import Ellipsoid

# "unverified": a set-membership estimator's set that the estimator cannot vouch for (rounding may
# have moved it off the truth); info["unverified_reason"] says why. Only "guaranteed" is guaranteed.
Kind = Literal["guaranteed", "unverified", "statistical", "point"]


@dataclass(frozen=True)
class History:
    """Trace of a recursive estimator: after every ``record_every`` samples, or (the OBE default)
    after every update step, the only rows where a set-membership estimate changes.

    index : (K,) int       sample index (0-based, the row of W just processed)
    centers : (K, p)       estimate after that sample
    log_volumes : (K,)     ln vol of the set after that sample (NaN for point estimators)
    shapes : (K, p, p)     ellipsoid shape matrices, only when asked for (teaching pictures)
    """

    index: np.ndarray
    centers: np.ndarray
    log_volumes: np.ndarray
    shapes: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.index.shape[0])


@dataclass
class Estimate:
    """The result of an estimator.

    method : str               e.g. "OBE-factorized (volume)", "WLS", "RLS"
    center : (p,)              the point estimate (ellipsoid centre, LS solution)
    ellipsoid : Ellipsoid      the guaranteed set (``kind="guaranteed"``), the set a guaranteed
                               estimator could not vouch for (``kind="unverified"``), or the
                               confidence ellipsoid at ``level`` (``kind="statistical"``); None if none
    intervals : (lo, hi)       per-parameter bounds, each (p,)
    kind : "guaranteed" | "unverified" | "statistical" | "point"
    level : float | None       confidence level of statistical sets (e.g. 0.95)
    names : tuple[str] | None  parameter names, from the model
    history : History | None   per-sample trace of recursive estimators
    outliers : (k,) int        indices of rows that contradicted the bounds (skipped)
    outlier_residuals : (k,)   their innovations y - w^T c at the time they were met
    info : dict                timings [s], update counts, solver status, std errors ...
    set : ConvexSet | None     the set itself, of any family (box, zonotope, polytope ...);
                               defaults to ``ellipsoid``, and ``ellipsoid`` is the set when the
                               set is an Ellipsoid (None otherwise)
    """

    method: str
    center: np.ndarray
    ellipsoid: Ellipsoid | None
    intervals: tuple[np.ndarray, np.ndarray]
    kind: Kind
    level: float | None = None
    names: tuple[str, ...] | None = None
    history: History | None = None
    outliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    outlier_residuals: np.ndarray = field(default_factory=lambda: np.zeros(0))
    info: dict = field(default_factory=dict)
    set: ConvexSet | None = None

    def __post_init__(self):
        if self.set is None:
            self.set = self.ellipsoid
        elif self.ellipsoid is None and isinstance(self.set, Ellipsoid):
            self.ellipsoid = self.set

    @property
    def p(self) -> int:
        return int(self.center.shape[0])

    @property
    def guaranteed(self) -> bool:
        return self.kind == "guaranteed"

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
        if "std_err" in self.info:
            df.insert(1, "std_err", np.asarray(self.info["std_err"]))
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
        ]
        for key, label in (
            ("n_samples", "Samples"),
            ("n_updates", "Updates"),
            ("condition_number", "cond(W)"),
            ("time_s", "Time [s]"),
        ):
            if key in self.info:
                v = self.info[key]
                head.append((label, f"{v:.4g}" if isinstance(v, float) else str(v)))
        if self.kind == "unverified":
            head.append(("Why", self.info.get("unverified_reason", "not given")))
        if self.kind in ("guaranteed", "unverified") or self.outliers.size:
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
