"""What a study file may name beside the estimators (:mod:`boundid.estimators.registry`) and the
robots (:mod:`boundid.models.registry`): the regression models and the options of the closed-loop
and tracking experiments; and :func:`make_robot`, the robot registry's factory with study-file errors.

Each options table is described by {option: default}; the default gives the type a study file
must write (see :meth:`boundid.studies.schema.Section.options`).
"""

from __future__ import annotations

import dataclasses

from boundid.errors import InputError, StudyError
from boundid.models import RobotModel
from boundid.models.registry import ROBOTS
from boundid.models.registry import make_robot as _make_robot


def closed_loop_options() -> dict:
    """experiment.options of the closed-loop (H4) experiment: fields of H4ExperimentConfig that a
    study may set (the others come from the study's own keys)."""
    from boundid.experiments.h4_pipeline import H4ExperimentConfig

    fields = {f.name: f.default for f in dataclasses.fields(H4ExperimentConfig)}
    return {k: fields[k] for k in ("amplifier_gain", "torque_limit", "bandwidth_hz", "substeps", "optimize_evals",
                                   "fast_period", "slow_fraction")}


def tracking_options() -> dict:
    """experiment.options of the tracking experiment (URDF arms): fields of TrackingConfig a study may set."""
    from boundid.experiments.tracking import OPTIONS, TrackingConfig

    fields = {f.name: f.default for f in dataclasses.fields(TrackingConfig)}
    return {k: fields[k] for k in OPTIONS}


def experiment_options(control: str) -> dict:
    """{option: default} of experiment.options for ``control`` (the open-loop experiment has none)."""
    return {"closed_loop": closed_loop_options, "tracking": tracking_options}.get(control, dict)()


REGRESSIONS = {
    "inverse_dynamic": "tau = Y(q, qd, qdd) theta; qd, qdd by central differences of low-passed q",
    "filtered_dynamic": "f*tau = (lambda s/(s+lambda)) Ya theta + f*(Yb theta); no acceleration",
    "supplied_energy": "int tau^T qd = H(t) - H(0) + int qd^T f(qd)",
    "filtered_power": "f*(tau^T qd) = (lambda s/(s+lambda)) (H - H(0)) + f*(qd^T f(qd))",
}


def make_robot(name: str, options: dict) -> RobotModel:
    """The named robot model with ``options`` (already type-checked against its Options); StudyError
    naming robot.options when the model refuses their values."""
    if name not in ROBOTS:
        raise StudyError(f"unknown robot {name!r}; choose among {', '.join(ROBOTS)}.")
    try:
        return _make_robot(name, options)
    except (InputError, TypeError) as exc:
        raise StudyError(f"robot.options for {name}: {exc}") from None
