"""A 1-dof pendulum with viscous friction, linear in 3 parameters: the teaching toy.

    J qdd + mgl sin q + b qd = tau          (q from the downward vertical, rad)

theta = (J [kg m^2], mgl [N m], b [N m s/rad]); J = m l^2 + I_c about the pivot. With three
parameters the feasible sets and ellipsoids of the estimators can be drawn in 3-D or projected
to 2-D planes. Energy H = 1/2 J qd^2 + mgl (1 - cos q); friction power b qd^2. It has no Coulomb
friction, so simulations of it are smooth and ``coulomb_width`` is ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boundid.errors import InputError
from boundid.models.base import RobotModel, per_state


@dataclass(frozen=True)
class LinearToyOptions:
    """robot.options of the linear toy: m [kg], l [m], I_c [kg m^2], b [N m s/rad], g [m/s^2]."""

    m: float = 1.0
    l: float = 0.5  # noqa: E741 (the paper's symbol)
    I_c: float = 0.01
    b: float = 0.1
    g: float = 9.81


class LinearToy(RobotModel):
    """Pendulum of mass ``m`` [kg] at distance ``l`` [m] from the pivot, own inertia ``I_c``
    [kg m^2] about its centre, viscous friction ``b`` [N m s/rad], gravity ``g`` [m/s^2].

    ``theta_true`` = (m l^2 + I_c, m g l, b); ``theta_prior`` = the same values (a designer who
    knows the drawing; set another prior in the study if you want a biased one).
    """

    name = "toy_pendulum"
    n_joints = 1
    Options = LinearToyOptions
    param_names = ("J", "mgl", "b")
    param_units = ("kg m^2", "N m", "N m s/rad")

    def __init__(self, m: float = 1.0, l: float = 0.5, I_c: float = 0.01, b: float = 0.1, g: float = 9.81):
        vals = {"m": m, "l": l, "I_c": I_c, "b": b, "g": g}
        if any(not np.isfinite(v) or v < 0 for v in vals.values()) or m * l * l + I_c <= 0:
            raise InputError(f"pendulum parameters must be finite, >= 0, with positive inertia; got {vals}.")
        self.theta_true = np.array([m * l * l + I_c, m * g * l, b], float)
        self.theta_prior = self.theta_true.copy()

    @per_state
    def regressor(self, q, qd, qdd) -> np.ndarray:
        (q, qd, qdd), _ = self._states(q, qd, qdd)
        return np.stack([qdd, np.sin(q), qd], axis=-1)

    @per_state
    def momentum_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        z = np.zeros_like(qd)
        return np.stack([qd, z, z], axis=-1)

    @per_state
    def remainder_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        return np.stack([np.zeros_like(qd), np.sin(q), qd], axis=-1)

    @per_state
    def energy_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        return np.column_stack([0.5 * qd[:, 0] ** 2, 1.0 - np.cos(q[:, 0]), np.zeros(q.shape[0])])

    @per_state
    def friction_power_regressor(self, qd) -> np.ndarray:
        (qd,), _ = self._states(qd, names=("qd",))
        z = np.zeros(qd.shape[0])
        return np.column_stack([z, z, qd[:, 0] ** 2])

    @per_state
    def mass_matrix(self, q, theta=None) -> np.ndarray:
        (q,), _ = self._states(q, names=("q",))
        return np.full((q.shape[0], 1, 1), self._theta(theta)[0])

    @per_state
    def bias_torque(self, q, qd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        th = self._theta(theta)
        return th[1] * np.sin(q) + th[2] * qd

    def fast_acceleration(self, q, qd, u, theta, coulomb_width: float) -> list[float]:
        """qdd for ONE state in plain floats, no input checks (the simulator's inner loop)."""
        return [(u[0] - theta[1] * math.sin(q[0]) - theta[2] * qd[0]) / theta[0]]
