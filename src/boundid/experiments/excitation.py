"""Excitation signals: the direct-drive paper's open-loop torques ([DirectDrivePaper] eqs. 31-32).

    tau_j(t) = (1 - exp(-r_j t)) a_j + sum_i A_ji sin(w_ji t + phi_ji)

    tau1 = (1 - e^{-0.8 t}) 29.0 + 68 sin(16 t + 0.1) + 9 sin(20 t + 0.15)   [N m]   (31)
    tau2 = (1 - e^{-1.8 t}) 1.2 + 8 sin(26 t + 0.08) + 2 sin(12 t + 0.34)    [N m]   (32)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boundid._validation import as_float_array
from boundid.errors import InputError


@dataclass(frozen=True)
class RampedMultisine:
    """Per joint j: a saturating ramp (1 - e^{-rate_j t}) offset_j plus a sum of sines.

    offset : (n,) N m           final value of the ramp
    rate : (n,) 1/s             ramp rate r_j
    amplitude : (n, k) N m      sine amplitudes A_ji
    frequency : (n, k) rad/s    angular frequencies w_ji
    phase : (n, k) rad          phases phi_ji

    Calling it with times t (N,) [s] returns the torques (N, n) [N m]; a scalar t gives (n,).
    """

    offset: tuple[float, ...]
    rate: tuple[float, ...]
    amplitude: tuple[tuple[float, ...], ...]
    frequency: tuple[tuple[float, ...], ...]
    phase: tuple[tuple[float, ...], ...]

    def __post_init__(self):
        n = len(self.offset)
        shapes = {np.shape(self.amplitude), np.shape(self.frequency), np.shape(self.phase)}
        if len(self.rate) != n or len(shapes) != 1 or len(next(iter(shapes))) != 2 or next(iter(shapes))[0] != n:
            raise InputError(
                "offset and rate need one entry per joint, amplitude/frequency/phase the same (n, k) shape; "
                f"got {n}, {len(self.rate)}, {np.shape(self.amplitude)}, {np.shape(self.frequency)}, "
                f"{np.shape(self.phase)}."
            )

    @classmethod
    def direct_drive_paper(cls) -> RampedMultisine:
        """The paper's torques (31)-(32) for the 2-dof direct-drive arm."""
        return cls(offset=(29.0, 1.2), rate=(0.8, 1.8),
                   amplitude=((68.0, 9.0), (8.0, 2.0)),
                   frequency=((16.0, 20.0), (26.0, 12.0)),
                   phase=((0.1, 0.15), (0.08, 0.34)))

    @property
    def n_joints(self) -> int:
        return len(self.offset)

    @property
    def max_frequency(self) -> float:
        """Highest angular frequency in the signal (rad/s): 26 for the paper's torques."""
        return float(np.max(self.frequency))

    def __call__(self, t) -> np.ndarray:
        t = as_float_array(t, "t")
        scalar = t.ndim == 0
        t = np.atleast_1d(t)[:, None, None]                                   # (N, 1, 1)
        ramp = (1.0 - np.exp(-np.asarray(self.rate) * t[:, :, 0])) * np.asarray(self.offset)
        sines = np.asarray(self.amplitude) * np.sin(np.asarray(self.frequency) * t + np.asarray(self.phase))
        tau = ramp + sines.sum(axis=2)
        return tau[0] if scalar else tau


def random_multisine(reference: RampedMultisine, rng: np.random.Generator,
                     frequency_band: tuple[float, float] | None = None) -> RampedMultisine:
    """A random torque law of ``reference``'s family within its peak torques.

    The same ramps (offset, rate) and number of sines per joint; each joint's total sine amplitude
    sum_i |A_ji| (hence the bound |offset_j| + sum_i |A_ji| on its torque) split at random
    (uniform on the simplex), frequencies uniform in ``frequency_band`` rad/s (default: 0.1 to 1
    times the reference's highest), phases uniform in [0, 2 pi). An excitation candidate for the
    open-loop experiment (:mod:`boundid.studies.excitation`).
    """
    amp = np.abs(np.asarray(reference.amplitude, dtype=float))
    n, k = amp.shape
    lo, hi = frequency_band or (0.1 * reference.max_frequency, reference.max_frequency)
    if not 0 < lo <= hi:
        raise InputError(f"frequency_band must be 0 < low <= high rad/s, got {frequency_band}.")
    split = rng.dirichlet(np.ones(k), size=n)
    return RampedMultisine(offset=tuple(reference.offset), rate=tuple(reference.rate),
                           amplitude=tuple(map(tuple, split * amp.sum(axis=1, keepdims=True))),
                           frequency=tuple(map(tuple, rng.uniform(lo, hi, (n, k)))),
                           phase=tuple(map(tuple, rng.uniform(0.0, 2 * np.pi, (n, k)))))
