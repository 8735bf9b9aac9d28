"""Preprocessing of sampled signals: differentiation, zero-phase low-pass, decimation.

Signals are arrays whose first axis is time (N, ...); ``h`` is the sample period in seconds.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from boundid._validation import as_float_array
from boundid.errors import InputError


def _signal(x, name: str, min_len: int = 2) -> np.ndarray:
    a = as_float_array(x, name)
    if a.ndim == 0 or a.shape[0] < min_len:
        raise InputError(f"{name} needs at least {min_len} samples along axis 0, got shape {a.shape}.")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains NaN or infinite samples; clean or interpolate them first.")
    return a


def _period(h: float) -> float:
    if not (np.isfinite(h) and h > 0):
        raise InputError(f"sample period h must be finite and > 0 s, got {h}.")
    return float(h)


def backward_difference(x, h: float) -> np.ndarray:
    """(x[k] - x[k-1]) / h, with the first sample repeated (the direct-drive paper's velocity)."""
    x, h = _signal(x, "x"), _period(h)
    d = np.empty_like(x)
    d[1:] = (x[1:] - x[:-1]) / h
    d[0] = d[1]
    return d


def central_difference(x, h: float) -> np.ndarray:
    """(x[k+1] - x[k-1]) / (2h), second-order one-sided differences at the ends."""
    x, h = _signal(x, "x", 3), _period(h)
    return np.gradient(x, h, axis=0, edge_order=2)


def zero_phase_lowpass(x, cutoff_hz: float, fs_hz: float, order: int = 4) -> np.ndarray:
    """Butterworth low-pass run forward and backward (no phase lag; ``sosfiltfilt``)."""
    x = _signal(x, "x", 3)
    if not 0 < cutoff_hz < 0.5 * fs_hz:
        raise InputError(
            f"cutoff_hz must lie in (0, fs/2) = (0, {0.5 * fs_hz:g}) Hz, got {cutoff_hz}."
        )
    sos = signal.butter(order, cutoff_hz, fs=fs_hz, output="sos")
    return signal.sosfiltfilt(sos, x, axis=0)


def main_lobe(fs_hz: float, filters) -> int:
    """Half-width [samples] of the main lobe of zero-phase Butterworth low-passes run one after the other.

    filters : (cutoff_hz, order) pairs (empty: none, 0). The combined impulse response of the
    ``sosfiltfilt`` passes is symmetric, largest at lag 0 and positive up to its first zero crossing
    (about 1 / (2 f_c) for one filter); returned is the last lag k >= 0 where it is still > 0.
    """
    filters = list(filters)
    if not filters:
        return 0
    length = int(np.ceil(20.0 * fs_hz / min(fc for fc, _ in filters)))  # the lobe ends within a few 1 / f_c
    x = np.zeros(2 * length + 1)
    x[length] = 1.0
    for cutoff_hz, order in filters:
        x = zero_phase_lowpass(x, cutoff_hz, fs_hz, order)
    return int(np.argmax(x[length:] <= 0.0)) - 1


def differentiate(q, h: float, cutoff_hz: float | None = None, order: int = 4):
    """Velocity and acceleration of a position signal by central differences.

    With ``cutoff_hz``, q is first low-passed with a zero-phase Butterworth filter (the H4
    paper's pipeline). Returns (q_filtered, qd, qdd), each the shape of q.
    """
    q = _signal(q, "q", 3)
    if cutoff_hz is not None:
        q = zero_phase_lowpass(q, cutoff_hz, 1.0 / _period(h), order)
    qd = central_difference(q, h)
    return q, qd, central_difference(qd, h)


#: Butterworth order of :func:`decimate`'s low-pass.
DECIMATION_ORDER = 8


def decimate(x, factor: int, cutoff_hz: float | None = None, fs_hz: float | None = None,
             order: int = DECIMATION_ORDER) -> np.ndarray:
    """Low-pass (zero-phase) then keep every ``factor``-th sample.

    Apply it to the torque and to every regressor column alike ("parallel filtering", Gautier):
    the regression is linear, so filtering both sides keeps it exact. The default cut-off is
    0.8 x the new Nyquist frequency.
    """
    x = _signal(x, "x", 3)
    if int(factor) != factor or factor < 1:
        raise InputError(f"decimation factor must be a positive integer, got {factor}.")
    factor = int(factor)
    if factor == 1:
        return x.copy()
    fs = 1.0 if fs_hz is None else fs_hz
    fc = 0.8 * 0.5 * fs / factor if cutoff_hz is None else cutoff_hz
    return zero_phase_lowpass(x, fc, fs, order)[::factor]


#: how a recorded torque is timed against the sample instants (:func:`torque_at_samples`)
TORQUE_TIMINGS = ("sample", "hold")


def torque_at_samples(tau, timing: str = "sample") -> np.ndarray:
    """The torque at the sample instants t_k from the recorded tau[k] (N, ...), for rows that pair it
    with the state at t_k (whose velocity and acceleration are central differences about t_k).

    "sample": tau[k] is the torque at t_k (measured at the sample instant): returned unchanged.
    "hold": tau[k] was held constant over [t_k, t_{k+1}) (zero-order hold: a simulator or a drive
    that applies each command until the next sample). A held value is, to O(h^2), the torque at the
    middle t_k + h/2 of its hold, so pairing it with t_k is half a sample late (an error of about
    (h/2) dtau/dt); the torque at t_k is the mean of the two holds around it, (tau[k-1] + tau[k]) / 2,
    which leaves an O(h^2) error. The first sample, which has no predecessor, takes the linear
    extrapolation (3 tau[0] - tau[1]) / 2 (second order, as :func:`central_difference` at the ends).
    A bound on the noise of tau[k] bounds the mean of two samples too; the extrapolated first
    sample's noise can reach twice it, but its row is among the edge rows the pipelines drop.
    """
    if timing not in TORQUE_TIMINGS:
        raise InputError(f"torque timing must be one of {', '.join(map(repr, TORQUE_TIMINGS))}, got {timing!r}.")
    tau = _signal(tau, "tau")
    if timing == "sample":
        return tau.copy()
    out = np.empty_like(tau)
    out[1:] = 0.5 * (tau[:-1] + tau[1:])
    out[0] = 1.5 * tau[0] - 0.5 * tau[1]
    return out
