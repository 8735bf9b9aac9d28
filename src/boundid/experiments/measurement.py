"""Measurement models: encoder quantisation and torque noise (Gaussian, bounded, outliers)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from boundid.errors import InputError


def quantize_angle(q, counts_per_rev: int) -> np.ndarray:
    """Encoder reading: angle rounded to the nearest of ``counts_per_rev`` steps per turn (rad)."""
    if counts_per_rev <= 0:
        raise InputError(f"counts_per_rev must be a positive integer, got {counts_per_rev}.")
    step = 2.0 * np.pi / counts_per_rev
    return np.round(np.asarray(q, float) / step) * step


@dataclass(frozen=True)
class TorqueNoise:
    """Additive torque noise.

    kind : "none" | "gaussian" | "uniform" | "bounded_outliers"
    level : N m. Standard deviation (gaussian) or half-width bound (uniform, bounded_outliers).
    outlier_rate : fraction of samples replaced by gross errors (bounded_outliers only)
    outlier_size : N m, gross errors are +-(level + outlier_size * U(1, 2))
    """

    kind: Literal["none", "gaussian", "uniform", "bounded_outliers"] = "none"
    level: float = 0.0
    outlier_rate: float = 0.0
    outlier_size: float = 0.0

    def __post_init__(self):
        if self.kind not in ("none", "gaussian", "uniform", "bounded_outliers"):
            raise InputError(
                f"noise kind must be one of none, gaussian, uniform, bounded_outliers; got {self.kind!r}."
            )
        if self.level < 0 or not 0 <= self.outlier_rate < 1 or self.outlier_size < 0:
            raise InputError("noise level, outlier_size must be >= 0 and outlier_rate in [0, 1).")

    @property
    def bound(self) -> float | None:
        """The hard bound on the inlier noise, if the noise has one (N m)."""
        return self.level if self.kind in ("uniform", "bounded_outliers") else (0.0 if self.kind == "none" else None)

    def sample(self, shape, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Noise of the given shape and a boolean mask of the outlier samples."""
        outliers = np.zeros(shape, dtype=bool)
        if self.kind == "none":
            return np.zeros(shape), outliers
        if self.kind == "gaussian":
            return rng.normal(0.0, self.level, shape), outliers
        e = rng.uniform(-self.level, self.level, shape)
        if self.kind == "bounded_outliers" and self.outlier_rate > 0:
            outliers = rng.random(shape) < self.outlier_rate
            k = int(outliers.sum())
            gross = self.level + self.outlier_size * rng.uniform(1.0, 2.0, k)
            e[outliers] = rng.choice([-1.0, 1.0], k) * gross
        return e, outliers
