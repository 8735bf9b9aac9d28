"""What a study file may name: robots, estimators, regression models."""

from __future__ import annotations

from collections.abc import Callable

from boundid.errors import StudyError
from boundid.models import DirectDriveArm, LinearToy, RobotModel


def _h4(options: dict) -> RobotModel:
    from boundid.models.h4 import H4Geometry, H4Robot

    try:
        return H4Robot(H4Geometry(**options)) if options else H4Robot()
    except TypeError as exc:
        raise StudyError(f"robot.options for h4: {exc}; the geometry fields are those of H4Geometry.") from None


def _direct_drive(options: dict) -> RobotModel:
    return DirectDriveArm(**options)


def _toy(options: dict) -> RobotModel:
    try:
        return LinearToy(**options)
    except TypeError as exc:
        raise StudyError(f"robot.options for linear_toy: {exc}.") from None


ROBOTS: dict[str, Callable[[dict], RobotModel]] = {
    "direct_drive": _direct_drive,
    "h4": _h4,
    "linear_toy": _toy,
}

ESTIMATORS = {
    "obe": "Optimal Bounding Ellipsoid, guaranteed set (form: standard | factorized; criterion: volume | "
           "trace | dasgupta-huang; e_max in the regression's unit)",
    "rls": "recursive least squares (theta0, P0, forgetting)",
    "ols": "ordinary least squares with Student-t intervals",
    "wls": "IDIM-WLS: rows weighted by each joint's residual standard deviation",
    "kalman": "Kalman filter on the parameters (theta0, P0, R, Q)",
}

REGRESSIONS = {
    "inverse_dynamic": "tau = Y(q, qd, qdd) theta; qd, qdd by central differences of low-passed q",
    "filtered_dynamic": "f*tau = (lambda s/(s+lambda)) Ya theta + f*(Yb theta); no acceleration",
    "supplied_energy": "int tau^T qd = H(t) - H(0) + int qd^T f(qd)",
    "filtered_power": "f*(tau^T qd) = (lambda s/(s+lambda)) (H - H(0)) + f*(qd^T f(qd))",
}


def make_robot(name: str, options: dict) -> RobotModel:
    if name not in ROBOTS:
        raise StudyError(f"unknown robot {name!r}; choose among {', '.join(ROBOTS)}.")
    return ROBOTS[name](options)
