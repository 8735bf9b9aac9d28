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


def read_table(path: str | Path, what: str = "recording") -> pd.DataFrame:
    """A CSV (.csv, .txt) or Parquet (.parquet) file as a DataFrame with at least one data row.

    InputError naming the file (``what`` says what it holds) when it is missing, empty, not a
    well-formed CSV, not UTF-8 text, or not a readable Parquet file (e.g. truncated).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{what} {path} not found.")
    if path.suffix not in (".parquet", ".csv", ".txt"):
        raise InputError(f"{what} {path}: unknown format {path.suffix!r}; use .csv or .parquet.")
    try:
        df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    except pd.errors.EmptyDataError:
        raise InputError(f"{what} {path} is empty: it needs a header row and data rows.") from None
    except pd.errors.ParserError as exc:
        raise InputError(f"{what} {path} is not a well-formed CSV file: {' '.join(str(exc).split())}") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} {path} is not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset "
                         f"{exc.start}); save it as UTF-8 CSV.") from None
    except (OSError, ValueError) as exc:  # pyarrow: ArrowInvalid (a ValueError), ArrowIOError (an OSError)
        raise InputError(f"{what} {path} cannot be read as Parquet ({type(exc).__name__}: {exc}); "
                         "is it complete? Write it again.") from None
    if len(df) == 0:
        raise InputError(f"{what} {path} has a header but no data rows.")
    return df


def numeric_columns(df: pd.DataFrame, columns, path: str | Path, what: str = "recording") -> np.ndarray:
    """The named columns as a finite float array (N, k); InputError naming the file, the column and
    the data row (1 = the first row after the header) of the first cell that is not a finite number."""
    columns = list(columns)
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise InputError(f"{what} {path} has no column(s) {missing}; its columns are {list(df.columns)}.")
    data = np.empty((len(df), len(columns)))
    for k, col in enumerate(columns):
        cells = df[col]
        values = pd.to_numeric(cells, errors="coerce")
        text = values.isna() & cells.notna()
        if text.any():
            r = int(np.argmax(text.to_numpy()))
            raise InputError(f"{what} {path}: column {col!r}, data row {r + 1}: {cells.iloc[r]!r} is not a number; "
                             "fix or drop that row.")
        data[:, k] = values.to_numpy(dtype=float)
    bad = ~np.isfinite(data)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise InputError(f"{what} {path}: {int(bad.sum())} empty or infinite value(s), the first in column "
                         f"{columns[c]!r} at data row {r + 1}; fill or drop those samples first.")
    return data


def read_recording(path: str | Path, time: str, q: list[str] | tuple[str, ...], tau: list[str] | tuple[str, ...],
                   rtol_sampling: float = 1e-3) -> Recording:
    """Read a CSV or Parquet recording, mapping the named columns to t, q and tau.

    The samples must be uniformly spaced (relative jitter below ``rtol_sampling``): the
    regression models filter and differentiate with a fixed sample period. Unreadable files and
    cells that are not numbers raise InputError naming the file, column and row.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"recording {path} not found; give its path relative to the study file.")
    df = read_table(path, "recording")
    wanted = [time, *q, *tau]
    if missing := [c for c in wanted if c not in df.columns]:
        raise InputError(
            f"recording {path} has no column(s) {missing}; its columns are {list(df.columns)}. "
            "Map them in the study file's [experiment.measured.columns]."
        )
    data = numeric_columns(df, wanted, path, "recording")
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
