"""A one-link pendulum with viscous and Coulomb friction: the smallest robot of the contract.

A rigid link of mass m [kg] turns about a horizontal axis; its centre of mass is lc [m] from the
axis and its inertia about the centre of mass I_c [kg m^2]; q = 0 hangs down. With
J = I_c + m lc^2 (parallel axis) the dynamics are

    tau = J qdd + m g lc sin q + b qd + fc sign(qd)

linear in theta = (J, mgl, b, fc) = (I_c + m lc^2, m g lc, b, fc) [kg m^2, N m, N m s/rad, N m].
Momentum J qd, energy H = J qd^2 / 2 + mgl (1 - cos q), friction power b qd^2 + fc |qd|.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boundid.errors import InputError
from boundid.models.base import RobotModel, coulomb, per_state


@dataclass(frozen=True)
class PendulumOptions:
    """robot.options of the pendulum: m [kg], lc [m], I_c [kg m^2], b [N m s/rad], fc [N m], g [m/s^2]."""

    m: float = 1.2
    lc: float = 0.4
    I_c: float = 0.02
    b: float = 0.05
    fc: float = 0.2
    g: float = 9.81


class Pendulum(RobotModel):
    """The one-link pendulum of the module docstring; ``theta_prior`` = ``theta_true`` (the drawing)."""

    name = "pendulum"
    n_joints = 1
    Options = PendulumOptions
    param_names = ("J", "mgl", "b", "fc")
    param_units = ("kg m^2", "N m", "N m s/rad", "N m")

    def __init__(self, m: float = 1.2, lc: float = 0.4, I_c: float = 0.02, b: float = 0.05, fc: float = 0.2,
                 g: float = 9.81):
        vals = {"m": m, "lc": lc, "I_c": I_c, "b": b, "fc": fc, "g": g}
        if any(not math.isfinite(v) or v < 0 for v in vals.values()) or I_c + m * lc * lc <= 0:
            raise InputError(f"pendulum options must be finite and >= 0 with a positive inertia; got {vals}.")
        self.theta_true = np.array([I_c + m * lc * lc, m * g * lc, b, fc])
        self.theta_prior = self.theta_true.copy()

    @per_state
    def regressor(self, q, qd, qdd) -> np.ndarray:
        (q, qd, qdd), _ = self._states(q, qd, qdd)
        return np.stack([qdd, np.sin(q), qd, np.sign(qd)], axis=-1)

    @per_state
    def momentum_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        z = np.zeros_like(qd)
        return np.stack([qd, z, z, z], axis=-1)

    @per_state
    def remainder_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        return np.stack([np.zeros_like(qd), np.sin(q), qd, np.sign(qd)], axis=-1)

    @per_state
    def energy_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        z = np.zeros(q.shape[0])
        return np.column_stack([0.5 * qd[:, 0] ** 2, 1.0 - np.cos(q[:, 0]), z, z])

    @per_state
    def friction_power_regressor(self, qd) -> np.ndarray:
        (qd,), _ = self._states(qd, names=("qd",))
        z = np.zeros(qd.shape[0])
        return np.column_stack([z, z, qd[:, 0] ** 2, np.abs(qd[:, 0])])

    @per_state
    def mass_matrix(self, q, theta=None) -> np.ndarray:
        (q,), _ = self._states(q, names=("q",))
        return np.full((q.shape[0], 1, 1), self._theta(theta)[0])

    @per_state
    def bias_torque(self, q, qd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        th = self._theta(theta)
        return th[1] * np.sin(q) + th[2] * qd + th[3] * coulomb(qd, coulomb_width)

    def fast_acceleration(self, q, qd, u, theta, coulomb_width: float) -> list[float]:
        """qdd for one state in plain floats: (u - mgl sin q - b qd - fc sign(qd)) / J."""
        v = qd[0]
        c = math.tanh(v / coulomb_width) if coulomb_width > 0 else float(np.sign(v))
        return [(u[0] - theta[1] * math.sin(q[0]) - theta[2] * v - theta[3] * c) / theta[0]]
