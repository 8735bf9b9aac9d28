"""Sizing a study's experiment before anything runs: long enough for its regression models, small
enough for the machine (the resource guard).

Resource guard: a study is refused up front when its experiment has more than ``max_samples``
samples x joints (default 2,000,000: 2,500 s of the direct-drive arm at 2.5 ms, 500 s of the H4 at
1 kHz) or when its estimated peak memory exceeds ``max_memory_gb`` (default 4 GB). Raise them with
the environment variables ``BOUNDID_MAX_SAMPLES`` and ``BOUNDID_MAX_MEMORY_GB``, e.g.
``BOUNDID_MAX_SAMPLES=1e8 BOUNDID_MAX_MEMORY_GB=32 boundid run study.toml``.

The memory estimate, 8 bytes x samples x joints x (p (2 R + 1) + 16) for p parameters and R
regression models, is the float64 arrays a run holds at once: each regression matrix and its
filtered intermediates (2 R p per sample and joint), the full-rate regressor of the inverse
dynamic model (p), the simulated and measured signals (16). Measured on the direct-drive arm
(p = 9, R = 4): 1.4 kB per sample against 1.55 kB estimated.
"""

from __future__ import annotations

import math
import os

from boundid.errors import ResourceError, StudyError

ENV_MAX_SAMPLES = "BOUNDID_MAX_SAMPLES"
ENV_MAX_MEMORY_GB = "BOUNDID_MAX_MEMORY_GB"
DEFAULT_MAX_SAMPLES = 2_000_000
DEFAULT_MAX_MEMORY_GB = 4.0

LOWPASS_ORDER = 4  # the zero-phase low-pass of q before differentiation (preprocessing.differentiate)
DECIMATION_ORDER = 8  # the zero-phase low-pass before decimation (preprocessing.decimate)


def _env_number(name: str, default: float) -> float:
    text = os.environ.get(name)
    if text is None or not text.strip():
        return default
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise StudyError(f"environment variable {name} = {text!r} must be a positive number; unset it for the "
                         f"default {default:g}.")
    return value


def budget() -> tuple[float, float]:
    """(max samples x joints, max memory in GB), from the environment or the defaults."""
    return _env_number(ENV_MAX_SAMPLES, DEFAULT_MAX_SAMPLES), _env_number(ENV_MAX_MEMORY_GB, DEFAULT_MAX_MEMORY_GB)


def memory_estimate(n_samples: int, n_joints: int, p: int, n_regressions: int) -> float:
    """Estimated peak bytes of a run (see the module docstring)."""
    return 8.0 * n_samples * n_joints * (p * (2 * n_regressions + 1) + 16)


def check_budget(n_samples: int, n_joints: int, p: int, n_regressions: int, where: str) -> None:
    """ResourceError with the numbers, the budget and how to raise it, when the run would exceed it."""
    max_samples, max_gb = budget()
    size = n_samples * n_joints
    gb = memory_estimate(n_samples, n_joints, p, n_regressions) / 1e9
    if size <= max_samples and gb <= max_gb:
        return
    raise ResourceError(
        f"{where}: {n_samples:,} samples x {n_joints} joints = {size:,.0f} values, estimated memory {gb:.3g} GB; "
        f"the budget is {max_samples:,.0f} values and {max_gb:g} GB. Shorten the experiment or lengthen its "
        f"sample period, or raise the budget with the environment variables {ENV_MAX_SAMPLES} and "
        f"{ENV_MAX_MEMORY_GB}.")


def _filtfilt_pad(order: int) -> int:
    """scipy.signal.sosfiltfilt's default padding (samples) of a Butterworth filter of this order:
    the signal must be longer."""
    return 3 * (2 * math.ceil(order / 2) + 1)


def minimum_duration(h: float, n_joints: int, p: int, regressions, lowpass_cutoff_hz: float | None,
                     decimation: int) -> dict[str, float]:
    """The shortest experiment [s] from which each regression model gets at least p rows.

    The inverse dynamic model drops 3 / f_c s at each end (zero-phase filter transients; f_c the
    low-pass cut-off, else 0.8 x the decimated Nyquist frequency) and keeps one sample in
    ``decimation``, n_joints rows each; its zero-phase filters also need more samples than their
    padding. The other models give about one row per sample (per joint for the filtered dynamic one).
    """
    out = {}
    for name in regressions:
        if name == "inverse_dynamic":
            fc = lowpass_cutoff_hz or 0.8 * 0.5 / (h * decimation)
            edge = 3.0 / fc
            rows_span = math.ceil(p / n_joints) * h * decimation
            pad = max(_filtfilt_pad(LOWPASS_ORDER) if lowpass_cutoff_hz else 0,
                      _filtfilt_pad(DECIMATION_ORDER) if decimation > 1 else 0)
            out[name] = max(2.0 * edge + rows_span, pad * h)
        else:
            out[name] = p * h
    return out


def check_cutoff(h: float, lowpass_cutoff_hz: float | None, decimation: int, where: str) -> None:
    """StudyError when the inverse dynamic model's low-pass cut-off (also its decimation filter's)
    is not below the Nyquist frequency of its rows, 0.5 / (h x decimation)."""
    nyquist = 0.5 / (h * decimation)
    if lowpass_cutoff_hz is not None and lowpass_cutoff_hz >= nyquist:
        raise StudyError(f"{where}: {lowpass_cutoff_hz:g} Hz must be below {nyquist:g} Hz, the Nyquist frequency of "
                         "the decimated rows (0.5 / (sample period x decimation)); lower it or the decimation.")


def check_length(duration_s: float, h: float, n_joints: int, p: int, regressions, lowpass_cutoff_hz: float | None,
                 decimation: int, where: str) -> None:
    """StudyError when an experiment of ``duration_s`` s at period ``h`` is too short for a regression model."""
    need = minimum_duration(h, n_joints, p, regressions, lowpass_cutoff_hz, decimation)
    short = {k: v for k, v in need.items() if duration_s < v * (1.0 + 1e-9)}
    if short:
        name, d = max(short.items(), key=lambda kv: kv[1])
        why = (f"its zero-phase filters drop {3.0 / (lowpass_cutoff_hz or 0.4 / (h * decimation)):.3g} s at each end"
               if name == "inverse_dynamic" else "about one row per sample")
        raise StudyError(f"{where} is {duration_s:g} s: too short for the {name} model, which needs more than "
                         f"{d:.3g} s for its {p} parameters ({why}); lengthen it.")
