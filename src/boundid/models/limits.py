"""Joint limits of a robot: position range, speed, acceleration and effort per joint.

Units per joint follow its type: rad, rad/s, rad/s^2, N m for a revolute joint; m, m/s, m/s^2, N
for a prismatic one. ``inf`` means "no limit given" (a continuous joint has no position limit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boundid._validation import as_float_array
from boundid.errors import InputError


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits, each (n,): lower, upper positions; velocity, acceleration, effort (> 0, may be inf)."""

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    effort: np.ndarray

    def __post_init__(self):
        arrs = {k: np.atleast_1d(as_float_array(getattr(self, k), k)) for k in
                ("lower", "upper", "velocity", "acceleration", "effort")}
        n = arrs["lower"].shape
        if any(a.ndim != 1 or a.shape != n for a in arrs.values()):
            raise InputError(f"joint limits must all have shape (n,); got { {k: a.shape for k, a in arrs.items()} }.")
        if np.any(np.isnan(np.concatenate(list(arrs.values())))):
            raise InputError("joint limits contain NaN; use inf for a limit that is not given.")
        if np.any(arrs["lower"] >= arrs["upper"]):
            raise InputError(f"each lower position limit must be below the upper one; got {arrs['lower']} and "
                             f"{arrs['upper']}.")
        for k in ("velocity", "acceleration", "effort"):
            if np.any(arrs[k] <= 0):
                raise InputError(f"{k} limits must be > 0 (inf when not given), got {arrs[k]}.")
        for k, a in arrs.items():
            object.__setattr__(self, k, a)

    @property
    def n_joints(self) -> int:
        return int(self.lower.shape[0])

    def middle(self) -> np.ndarray:
        """Centre of each position range (0 for a joint without position limits)."""
        mid = 0.5 * (self.lower + self.upper)
        return np.where(np.isfinite(mid), mid, 0.0)

    def sample_positions(self, rng: np.random.Generator, n_samples: int) -> np.ndarray:
        """Uniform positions (n_samples, n) in the range, clipped to [-pi, pi] where unbounded."""
        lo, hi = np.maximum(self.lower, -np.pi), np.minimum(self.upper, np.pi)
        return rng.uniform(lo, hi, (n_samples, self.n_joints))
