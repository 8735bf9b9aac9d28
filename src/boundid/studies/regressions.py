"""The regression models of a study, built from its recording (the runner and the validation
experiment both use them)."""

from __future__ import annotations

from boundid.experiments import regression as reg_builders
from boundid.experiments.filters import align
from boundid.experiments.h4_pipeline import IdentificationDesign, identification_design
from boundid.experiments.recording import Recording
from boundid.experiments.regression import Regression
from boundid.models import RobotModel
from boundid.studies.config import PreprocessingConfig


def inverse_dynamic_rows(model: RobotModel, rec: Recording, pp: PreprocessingConfig) -> Regression:
    """IDIM rows by the H4 paper's pipeline
    (:func:`~boundid.experiments.h4_pipeline.identification_regression`, with the analytic
    Jdot rather than the paper's central difference, so any robot model works): zero-phase
    low-pass and central differences for qd, qdd; torques and regressor columns low-pass filtered
    and decimated together ("parallel filtering"); the first and last ``3 / f_c`` seconds, where the
    zero-phase filters start from assumed edge values, dropped; with ``min_speed_rad_s``, the rows of
    a joint within the filters' reach (:func:`boundid.experiments.h4_pipeline.low_speed_window`) of a
    sample where it is slower than its threshold, dropped too (counted in the result's ``dropped``).
    The torque is timed by ``torque_timing`` before its low-pass: "sample" pairs tau[k] with the
    state at t_k, "hold" (a torque held over [t_k, t_{k+1})) gives the row at t_k the mean
    (tau[k-1] + tau[k]) / 2 (:func:`boundid.experiments.preprocessing.torque_at_samples`)."""
    return inverse_dynamic_design(model, rec, pp).regression(rec.tau)


def inverse_dynamic_design(model: RobotModel, rec: Recording, pp: PreprocessingConfig) -> IdentificationDesign:
    """The angles' half of :func:`inverse_dynamic_rows` (its torque is ignored; the design keeps
    ``pp.torque_timing`` and applies it to every torque it is given): reuse it for recordings that
    differ only in their torque (new draws of the torque noise)."""
    h = rec.h
    fc = pp.lowpass_cutoff_hz or 0.8 * 0.5 / (h * pp.decimation)
    return identification_design(model, rec.t, rec.q, pp.lowpass_cutoff_hz, pp.decimation, decimation_cutoff_hz=fc,
                                 jdot="analytic", edge_s=3.0 / fc, min_speed=pp.min_speed_rad_s, slow_window_s=None,
                                 torque_timing=pp.torque_timing)


def build_regressions(model: RobotModel, rec: Recording, pp: PreprocessingConfig,
                      names: tuple[str, ...]) -> dict[str, Regression]:
    """The named regression models built from one recording."""
    out: dict[str, Regression] = {}
    aligned = None
    for name in names:
        if name == "inverse_dynamic":
            out[name] = inverse_dynamic_rows(model, rec, pp)
            continue
        if aligned is None:
            aligned = align(rec.q, rec.tau, rec.h, pp.pairing, t0=float(rec.t[0]))
        a = aligned
        if name == "supplied_energy":
            out[name] = reg_builders.supplied_energy(model, a.q, a.qd, a.tau, a.t)
        else:
            build = getattr(reg_builders, name)
            out[name] = build(model, a.q, a.qd, a.tau, a.t, lam=pp.lambda_rad_s, discretisation=pp.discretisation)
    return out
