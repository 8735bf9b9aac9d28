"""Regression builders: stacked observation matrices (W, y) from sampled robot data.

Four models, generic over any :class:`boundid.models.RobotModel`:

- inverse dynamic   tau = Y(q, qd, qdd) theta                         (needs qdd)
- filtered dynamic  f*tau = (lambda s/(s+lambda)) Ya theta + f*(Yb theta), f = lambda/(s+lambda)
- supplied energy   int tau^T qd = [H(t) - H(0)] + int qd^T f(qd)
- filtered power    f*(tau^T qd) = (lambda s/(s+lambda)) (H - H(0)) + f*(qd^T f(qd))

Rows are stacked sample-major: for a model with n joints, rows k*n .. k*n + n - 1 are the joints
of sample k. Energy and power models give one row per sample (``joint = -1``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from boundid._validation import as_regression
from boundid.errors import InputError


@dataclass
class Regression:
    """A linear regression y = W theta + e built from robot data.

    W : (N, p)          observation matrix
    y : (N,)            measured side (torques in N m, energies in J, powers in W)
    joint : (N,) int    joint of each row (0-based), -1 for scalar (energy/power) rows
    sample : (N,) int   index of the sample the row comes from
    t : (N,)            time of the row [s]
    model : str         "inverse_dynamic" | "filtered_dynamic" | "supplied_energy" | "filtered_power"
    param_names : tuple names of the p parameters (from the robot model)
    unit : str          unit of y ("N m", "J", "W")
    info : dict         how it was built (filter lambda [rad/s], discretisation, decimation ...)
    """

    W: np.ndarray
    y: np.ndarray
    joint: np.ndarray
    sample: np.ndarray
    t: np.ndarray
    model: str
    param_names: tuple[str, ...]
    unit: str = "N m"
    info: dict = field(default_factory=dict)

    def __post_init__(self):
        self.W, self.y = as_regression(self.W, self.y)
        n = self.W.shape[0]
        for name in ("joint", "sample", "t"):
            a = np.asarray(getattr(self, name))
            if a.shape != (n,):
                raise InputError(f"Regression.{name} must have shape ({n},), got {a.shape}.")
            setattr(self, name, a)
        if len(self.param_names) != self.W.shape[1]:
            raise InputError(
                f"{len(self.param_names)} parameter names for {self.W.shape[1]} columns of W."
            )

    @property
    def n_rows(self) -> int:
        return int(self.W.shape[0])

    def rows_of_joint(self, j: int) -> Regression:
        """The sub-regression of joint ``j`` (rows in time order)."""
        return self.subset(self.joint == j)

    def subset(self, mask) -> Regression:
        """The rows selected by a boolean mask or an index array."""
        return Regression(self.W[mask], self.y[mask], self.joint[mask], self.sample[mask],
                          self.t[mask], self.model, self.param_names, self.unit, dict(self.info))


def stack_joint_rows(Y: np.ndarray, tau: np.ndarray, t: np.ndarray, model: str,
                     param_names: tuple[str, ...], unit: str = "N m", info: dict | None = None
                     ) -> Regression:
    """Stack per-sample regressors Y (N, n, p) and targets tau (N, n) sample-major into rows."""
    Y = np.asarray(Y, float)
    tau = np.asarray(tau, float)
    if Y.ndim != 3 or tau.shape != Y.shape[:2]:
        raise InputError(f"Y must be (N, n, p) and tau (N, n); got {Y.shape} and {tau.shape}.")
    N, n, p = Y.shape
    return Regression(
        W=Y.reshape(N * n, p),
        y=tau.reshape(N * n),
        joint=np.tile(np.arange(n), N),
        sample=np.repeat(np.arange(N), n),
        t=np.repeat(np.asarray(t, float), n),
        model=model,
        param_names=tuple(param_names),
        unit=unit,
        info=dict(info or {}),
    )


def inverse_dynamic(model, q, qd, qdd, tau, t) -> Regression:
    """tau = Y(q, qd, qdd) theta, one row per joint per sample (the IDIM baseline for WLS/OBE)."""
    Y = model.regressor(q, qd, qdd)
    return stack_joint_rows(Y, tau, t, "inverse_dynamic", model.param_names)
