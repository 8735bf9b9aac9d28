"""Measured data: a robot's recording of time, joint positions and torques (CSV or Parquet; one file,
or positions and torques in two), joint-side or motor-side through a transmission."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.errors import InputError
from boundid.experiments.transmission import Transmission

#: the units a study file may declare, as factors to rad and s
ANGLE_UNITS = {"rad": 1.0, "deg": np.pi / 180}
TIME_UNITS = {"s": 1.0, "ms": 1e-3}
#: plausibility: a robot's recording samples faster than 10 Hz and slower than 100 kHz, and a joint
#: spans at most 100 rad (16 turns) over it; beyond, a unit (or the motor side) is the likely mistake
MAX_PERIOD_S = 0.1
MIN_PERIOD_S = 1e-5
MAX_ANGLE_SPAN_RAD = 100.0
#: joint-side speed [rad/s] (over 10 ms) no robot joint reaches (~380 rpm): angles in degrees read as
#: radians multiply speeds by 57, motor-side angles by the gear ratio
MAX_JOINT_SPEED_RAD_S = 40.0


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


def read_recording(path: str | Path, time: str | None, q: list[str] | tuple[str, ...],
                   tau: list[str] | tuple[str, ...], rtol_sampling: float = 1e-3, *, tau_file: str | Path | None = None,
                   sample_period_s: float | None = None, angle_unit: str = "rad", time_unit: str = "s",
                   transmission: Transmission | None = None) -> Recording:
    """Read a CSV or Parquet recording, mapping the named columns to t [s], q [rad] and tau [N m].

    path : the recording, or its positions (and time column) when ``tau_file`` holds the torques
        (the two files then have one row per sample each, the same count)
    time : the time column in ``time_unit`` ("s" or "ms"), or None with ``sample_period_s`` [s]
    q, tau : the position columns in ``angle_unit`` ("rad" or "deg") and the torque columns, one per
        joint (or motor); joint side in N m, or motor side converted by ``transmission``
        (:mod:`boundid.experiments.transmission`: q = R^-1 q_m + q_0, tau = R^T (k * signal))

    The samples must be uniformly spaced (relative jitter below ``rtol_sampling``): the regression
    models filter and differentiate with a fixed sample period. Unreadable files and cells that are
    not numbers raise InputError naming the file, column and row; so do implausible units (a period
    over 0.1 s, joint angles spanning over 100 rad or moving faster than 40 rad/s, a column that
    never changes), naming the likely mistake and the study-file key that fixes it.
    """
    path = Path(path)
    if (time is None) == (sample_period_s is None):
        raise InputError(f"recording {path}: give the time column (experiment.measured.columns.time) or "
                         f"experiment.measured.sample_period_s{', not both' if time is not None else ''}.")
    tau_path = path if tau_file is None else Path(tau_file)
    for p in dict.fromkeys((path, tau_path)):
        if not p.is_file():
            raise InputError(f"recording {p} not found; give its path relative to the study file.")
    df = read_table(path, "recording")
    df_tau = df if tau_file is None else read_table(tau_path, "recording")
    for p, frame, wanted in ((path, df, [*([time] if time else []), *q]), (tau_path, df_tau, list(tau))):
        if missing := [c for c in wanted if c not in frame.columns]:
            raise InputError(f"recording {p} has no column(s) {missing}; its columns are {list(frame.columns)}. "
                             "Map them in the study file's [experiment.measured.columns].")
    if len(df) != len(df_tau):
        raise InputError(f"recording: the positions file {path} has {len(df):,} rows, the torques file {tau_path} "
                         f"{len(df_tau):,}; experiment.measured.file and tau_file must hold the same samples, one "
                         "row each.")
    data = numeric_columns(df, [*([time] if time else []), *q], path, "recording")
    raw_q, raw_tau = data[:, 1 if time else 0:], numeric_columns(df_tau, tau, tau_path, "recording")
    t = _times(path, time, data[:, 0] if time else None, len(df), sample_period_s, time_unit, rtol_sampling)
    for p, columns, values, why in ((path, q, raw_q, "a joint that does not move cannot be identified"),
                                    (tau_path, tau, raw_tau, "a torque that never changes measures nothing")):
        if (still := np.flatnonzero(np.ptp(values, axis=0) == 0)).size:
            raise InputError(f"recording {p}: column {columns[still[0]]!r} holds one value ({values[0, still[0]]:g}) "
                             f"throughout and {why}; is it the right column in [experiment.measured.columns]?")
    q_rad = raw_q * ANGLE_UNITS[angle_unit]
    if transmission is None:
        q_joint, tau_joint = q_rad, raw_tau
    elif transmission.n != len(q):
        raise InputError(f"recording {path}: the transmission has {transmission.n} gear ratios, the recording "
                         f"{len(q)} position columns; give one ratio per joint.")
    else:
        q_joint, tau_joint = transmission.to_joint(q_rad, raw_tau)
    unit, side = 'set experiment.measured.angle_unit = "deg"', "give [experiment.measured.transmission]"
    fix = {(False, "rad"): f"are the angles in degrees, or motor-side? {unit}, or {side}",
           (False, "deg"): f"are the angles motor-side? {side}",
           (True, "rad"): f"are the motor angles in degrees? {unit}, or check the gear_ratios",
           (True, "deg"): "check the transmission's gear_ratios and coupling"}[transmission is not None, angle_unit]
    span = np.ptp(q_joint, axis=0)
    if span.size and span[j := int(np.argmax(span))] > MAX_ANGLE_SPAN_RAD:
        raise InputError(f"recording {path}: joint {j + 1} spans {span[j]:.4g} rad ({span[j] / (2 * np.pi):.3g} "
                         f"turns) over the recording; {fix}.")
    m = max(1, int(round(0.01 / float(np.median(np.diff(t)))))) if t.size > 1 else 1
    if t.size > m:
        speed = np.abs(q_joint[m:] - q_joint[:-m]).max(axis=0) / (t[m:] - t[:-m]).min()
        if speed[j := int(np.argmax(speed))] > MAX_JOINT_SPEED_RAD_S:
            raise InputError(f"recording {path}: joint {j + 1} moves at {speed[j]:.4g} rad/s "
                             f"({speed[j] * 30 / np.pi:.0f} rpm), faster than any robot joint; {fix}.")
    return Recording(t=t, q=q_joint, tau=tau_joint)


def _times(path: Path, time: str | None, column: np.ndarray | None, n_rows: int, sample_period_s: float | None,
           time_unit: str, rtol_sampling: float) -> np.ndarray:
    """The sample times t (N,) [s]: the time column (in ``time_unit``), checked for strictly increasing,
    uniform and plausible steps, or k * sample_period_s [s]."""
    if time is None:
        if n_rows < 3:
            raise InputError(f"recording {path}: {n_rows} samples; at least 3 are needed.")
        if sample_period_s > MAX_PERIOD_S:
            raise InputError(f"recording {path}: sample period {sample_period_s:g} s ({1 / sample_period_s:.3g} Hz): "
                             f"is it in ms? experiment.measured.sample_period_s is in s ({sample_period_s:g} ms is "
                             f"{sample_period_s * 1e-3:g}).")
        return np.arange(n_rows) * sample_period_s
    t = column * TIME_UNITS[time_unit]
    dt = np.diff(t)
    if len(t) < 3 or np.any(dt <= 0):
        raise InputError(f"recording {path}: time column {time!r} must increase strictly over >= 3 samples.")
    h = np.median(dt)
    if np.max(np.abs(dt - h)) > rtol_sampling * h:
        raise InputError(
            f"recording {path}: samples are not uniformly spaced (period {h:g} s, worst gap "
            f"{dt[np.argmax(np.abs(dt - h))]:g} s); resample to a fixed period first."
        )
    if time_unit == "s" and h > MAX_PERIOD_S:
        raise InputError(f"recording {path}: sample period {h:g} s from time column {time!r}: is the time column in "
                         'ms? set experiment.measured.time_unit = "ms".')
    if time_unit == "ms" and h < MIN_PERIOD_S:
        raise InputError(f"recording {path}: sample period {h:g} s ({1 / h:.3g} Hz) from time column {time!r} in ms: "
                         'is it in s? set experiment.measured.time_unit = "s".')
    return t
