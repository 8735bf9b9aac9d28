"""Measured data: a robot's recording of time, joint positions and torques (CSV or Parquet)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.errors import InputError


@dataclass(frozen=True)
class Recording:
    """Uniformly sampled joint data.

    t : (N,) [s]    q : (N, n) [rad]    tau : (N, n) [N m]    h : sample period [s]
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray

    @property
    def h(self) -> float:
        return float(np.median(np.diff(self.t)))

    @property
    def n_joints(self) -> int:
        return int(self.q.shape[1])

    def to_frame(self, q_names=None, tau_names=None) -> pd.DataFrame:
        n = self.n_joints
        q_names = q_names or [f"q{j + 1}" for j in range(n)]
        tau_names = tau_names or [f"tau{j + 1}" for j in range(n)]
        df = pd.DataFrame({"t": self.t})
        for j in range(n):
            df[q_names[j]] = self.q[:, j]
            df[tau_names[j]] = self.tau[:, j]
        return df


def write_recording(rec: Recording, path: str | Path) -> Path:
    """Write a recording as CSV or Parquet (by the file's suffix), columns t, q1.., tau1.."""
    path = Path(path)
    df = rec.to_frame()
    if path.suffix == ".parquet":
        df.to_parquet(path, index=False)
    else:
        df.to_csv(path, index=False, float_format="%.17g")
    return path


def read_recording(path: str | Path, time: str, q: list[str] | tuple[str, ...], tau: list[str] | tuple[str, ...],
                   rtol_sampling: float = 1e-3) -> Recording:
    """Read a CSV or Parquet recording, mapping the named columns to t, q and tau.

    The samples must be uniformly spaced (relative jitter below ``rtol_sampling``): the
    regression models filter and differentiate with a fixed sample period.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"recording {path} not found; give its path relative to the study file.")
    if path.suffix == ".parquet":
        df = pd.read_parquet(path)
    elif path.suffix in (".csv", ".txt"):
        df = pd.read_csv(path)
    else:
        raise InputError(f"recording {path}: unknown format {path.suffix!r}; use .csv or .parquet.")
    wanted = [time, *q, *tau]
    missing = [c for c in wanted if c not in df.columns]
    if missing:
        raise InputError(
            f"recording {path} has no column(s) {missing}; its columns are {list(df.columns)}. "
            "Map them in the study file's [experiment.measured.columns]."
        )
    data = df[wanted].to_numpy(dtype=float)
    bad = ~np.isfinite(data)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise InputError(
            f"recording {path}: {int(bad.sum())} empty or non-numeric value(s), the first in column "
            f"{wanted[c]!r} at row {r}; fill or drop those samples first."
        )
    t = data[:, 0]
    dt = np.diff(t)
    if len(t) < 3 or np.any(dt <= 0):
        raise InputError(f"recording {path}: time column {time!r} must increase strictly over >= 3 samples.")
    h = np.median(dt)
    if np.max(np.abs(dt - h)) > rtol_sampling * h:
        raise InputError(
            f"recording {path}: samples are not uniformly spaced (period {h:g} s, worst gap "
            f"{dt[np.argmax(np.abs(dt - h))]:g} s); resample to a fixed period first."
        )
    n = len(q)
    return Recording(t=t, q=data[:, 1 : 1 + n], tau=data[:, 1 + n :])
