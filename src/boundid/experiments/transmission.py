"""A robot's transmission: motor-side signals (encoder angles, currents) to joint-side ones.

A robot's controller logs what its motors see. With n joints and n motors, the motor angles are
linear in the joint angles, and virtual work (tau_m^T dq_m = tau^T dq) gives the joint torques:

    q_m = R q + c     ->    q = R^-1 q_m + q_0        q_0 = -R^-1 c (joint_offsets_rad)
    tau_m = k * i     ->    tau = R^T tau_m

R (n, n) = diag(gear_ratios) plus the coupling terms R[motor, joint] = ratio (a wrist whose
motor turns with an earlier joint as well as its own), k (n,) the torque gains [N m per unit of
the logged signal, e.g. per A] and q_0 (n,) [rad] the joint-side offsets, added after the
conversion (where the joint's zero differs from the one the encoders count from).

The Staubli TX40 (FIGAROH's example): gear_ratios = [32, 32, 45, -48, 45, 32], motor 6 turns
with q5 + q6 (coupling [[6, 5, 32]], i.e. R[5, 4] = 32 in 0-based terms), q_0 = [0, -pi/2, pi/2,
0, 0, 0], k = 1 (the log holds motor torques).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boundid.errors import InputError

#: R is refused as singular above this condition number (2-norm)
MAX_CONDITION = 1e12


class TransmissionError(InputError):
    """A transmission that cannot convert: ``key`` names the field (gear_ratios, coupling,
    joint_offsets_rad, torque_gains), ``reason`` says what is wrong and what to write."""

    def __init__(self, key: str, reason: str):
        super().__init__(f"transmission.{key}: {reason}")
        self.key, self.reason = key, reason


def _finite(key: str, values, n: int | None = None) -> tuple[float, ...]:
    """``values`` as floats; TransmissionError unless there are n (if given), all finite numbers."""
    values = tuple(values)
    if n is not None and len(values) != n:
        raise TransmissionError(key, f"has {len(values)} number(s), gear_ratios {n}: give one per joint.")
    for j, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise TransmissionError(key, f"entry {j + 1} is {v!r}: every entry must be a finite number.")
    return tuple(float(v) for v in values)


@dataclass(frozen=True)
class Transmission:
    """The linear transmission of n motors to n joints, checked when made (TransmissionError).

    gear_ratios : (n,) diagonal of R, sign allowed (a motor turning the other way)
    coupling : entries (motor, joint, ratio), 1-based, motor != joint: R[motor - 1, joint - 1] = ratio
    joint_offsets_rad : (n,) q_0 [rad], added to the converted angles; None: zero
    torque_gains : (n,) k, tau_m = k * logged signal [N m per unit]; None: 1 (the log holds N m)
    """

    gear_ratios: tuple[float, ...]
    coupling: tuple[tuple[int, int, float], ...] = ()
    joint_offsets_rad: tuple[float, ...] | None = None
    torque_gains: tuple[float, ...] | None = None

    def __post_init__(self):
        ratios = _finite("gear_ratios", self.gear_ratios)
        n = len(ratios)
        if n == 0:
            raise TransmissionError("gear_ratios", "is empty: give one ratio per joint (motor turns per joint turn).")
        seen = set()
        for entry in self.coupling:
            if (len(entry) != 3 or any(isinstance(x, bool) or not isinstance(x, int) for x in entry[:2])
                    or not 1 <= entry[0] <= n or not 1 <= entry[1] <= n):
                raise TransmissionError("coupling", f"entry {list(entry)!r} must be [motor, joint, ratio] with motor "
                                                    f"and joint integers in 1..{n}.")
            if entry[0] == entry[1]:
                raise TransmissionError("coupling", f"entry {list(entry)!r} is on the diagonal, which gear_ratios "
                                                    "sets; coupling adds R[motor, joint] with motor != joint.")
            if tuple(entry[:2]) in seen:
                raise TransmissionError("coupling", f"names motor {entry[0]}, joint {entry[1]} twice: give one entry.")
            if isinstance(entry[2], bool) or not isinstance(entry[2], int | float) or not math.isfinite(entry[2]):
                raise TransmissionError("coupling", f"entry {list(entry)!r}: the ratio must be a finite number.")
            seen.add(tuple(entry[:2]))
        offsets = None if self.joint_offsets_rad is None else _finite("joint_offsets_rad", self.joint_offsets_rad, n)
        gains = None if self.torque_gains is None else _finite("torque_gains", self.torque_gains, n)
        if gains is not None and 0.0 in gains:
            raise TransmissionError("torque_gains", f"entry {gains.index(0.0) + 1} is 0: that motor's torque would "
                                                    "vanish; give its N m per unit of the logged signal.")
        object.__setattr__(self, "gear_ratios", ratios)
        object.__setattr__(self, "coupling", tuple((int(m), int(j), float(r)) for m, j, r in self.coupling))
        object.__setattr__(self, "joint_offsets_rad", offsets)
        object.__setattr__(self, "torque_gains", gains)
        cond = np.linalg.cond(self.matrix)
        if not cond < MAX_CONDITION:
            key = "coupling" if self.coupling else "gear_ratios"
            raise TransmissionError(key, f"gives a singular R (condition number {cond:.3g}): the motor angles do not "
                                         "determine the joint angles; check the ratios (a zero, or two motors "
                                         "turning alike with the same joints).")

    @property
    def n(self) -> int:
        return len(self.gear_ratios)

    @property
    def matrix(self) -> np.ndarray:
        """R (n, n): q_m = R q + c [motor rad per joint rad]."""
        R = np.diag(np.asarray(self.gear_ratios, dtype=float))
        for motor, joint, ratio in self.coupling:
            R[motor - 1, joint - 1] = ratio
        return R

    def _offsets(self) -> np.ndarray:
        return np.zeros(self.n) if self.joint_offsets_rad is None else np.asarray(self.joint_offsets_rad)

    def _gains(self) -> np.ndarray:
        return np.ones(self.n) if self.torque_gains is None else np.asarray(self.torque_gains)

    def to_joint(self, q_motor: np.ndarray, signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Motor side to joint side: q = R^-1 q_m + q_0 [rad], tau = R^T (k * signal) [N m].

        q_motor : (N, n) motor angles [rad];  signal : (N, n) logged torque signal (tau_m / k)
        """
        R = self.matrix
        q = np.linalg.solve(R, np.asarray(q_motor, dtype=float).T).T + self._offsets()
        tau = (np.asarray(signal, dtype=float) * self._gains()) @ R
        return q, tau

    def to_motor(self, q: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The inverse of :meth:`to_joint`: what the motors log for joint angles q (N, n) [rad] and
        torques tau (N, n) [N m]: q_m = R (q - q_0) [rad], signal = R^-T tau / k."""
        R = self.matrix
        q_motor = (np.asarray(q, dtype=float) - self._offsets()) @ R.T
        signal = np.linalg.solve(R.T, np.asarray(tau, dtype=float).T).T / self._gains()
        return q_motor, signal
