"""What a study file may name: robots (with their options), regression models, and the options of
the closed-loop experiment (the estimators are in :mod:`boundid.estimators.registry`).

Each options table is described by {option: default}; the default gives the type a study file
must write (see :meth:`boundid.studies.schema.Section.options`).
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable

from boundid.errors import InputError, StudyError
from boundid.models import DirectDriveArm, LinearToy, RobotModel
from boundid.models.direct_drive import PHYSICAL


def _h4(options: dict) -> RobotModel:
    from boundid.models.h4 import H4Geometry, H4Robot

    return H4Robot(H4Geometry(**options)) if options else H4Robot()


def _h4_options() -> dict:
    from boundid.models.h4 import H4Geometry

    return {f.name: f.default for f in dataclasses.fields(H4Geometry) if f.init}


def _keyword_defaults(cls) -> dict:
    return {k: p.default for k, p in inspect.signature(cls.__init__).parameters.items()
            if p.default is not inspect.Parameter.empty}


ROBOTS: dict[str, Callable[[dict], RobotModel]] = {
    "direct_drive": lambda options: DirectDriveArm(**options),
    "h4": _h4,
    "linear_toy": lambda options: LinearToy(**options),
}

# robot.options of each robot: {option: default} (physical values in SI units; the H4 geometry in m, rad)
ROBOT_OPTIONS: dict[str, Callable[[], dict]] = {
    "direct_drive": lambda: dict(PHYSICAL),
    "h4": _h4_options,
    "linear_toy": lambda: _keyword_defaults(LinearToy),
}


def closed_loop_options() -> dict:
    """experiment.options of the closed-loop (H4) experiment: fields of H4ExperimentConfig that a
    study may set (the others come from the study's own keys)."""
    from boundid.experiments.h4_pipeline import H4ExperimentConfig

    fields = {f.name: f.default for f in dataclasses.fields(H4ExperimentConfig)}
    return {k: fields[k] for k in ("amplifier_gain", "torque_limit", "bandwidth_hz", "substeps", "optimize_evals",
                                   "fast_period", "slow_fraction")}


REGRESSIONS = {
    "inverse_dynamic": "tau = Y(q, qd, qdd) theta; qd, qdd by central differences of low-passed q",
    "filtered_dynamic": "f*tau = (lambda s/(s+lambda)) Ya theta + f*(Yb theta); no acceleration",
    "supplied_energy": "int tau^T qd = H(t) - H(0) + int qd^T f(qd)",
    "filtered_power": "f*(tau^T qd) = (lambda s/(s+lambda)) (H - H(0)) + f*(qd^T f(qd))",
}


def make_robot(name: str, options: dict) -> RobotModel:
    """The named robot model with ``options`` (already type-checked against ROBOT_OPTIONS[name]);
    StudyError naming robot.options when the model refuses their values."""
    if name not in ROBOTS:
        raise StudyError(f"unknown robot {name!r}; choose among {', '.join(ROBOTS)}.")
    try:
        return ROBOTS[name](options)
    except (InputError, TypeError) as exc:
        raise StudyError(f"robot.options for {name}: {exc}") from None
