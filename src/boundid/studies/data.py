"""Getting a study's data: simulate the robot and measure it, or read a recording."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from boundid.errors import StudyError
from boundid.experiments.excitation import RampedMultisine
from boundid.experiments.recording import Recording, read_recording
from boundid.experiments.simulation import measure, simulate_open_loop
from boundid.models import RobotModel
from boundid.studies import sizing
from boundid.studies.config import StudyConfig
from boundid.studies.h4_experiment import closed_loop_data


@dataclass
class StudyData:
    """recording: what identification sees (measured q [rad], tau [N m] at t [s]).
    validation: a second, different experiment for cross-validation (or None).
    excitation: the open-loop torque law (for re-simulation), if any.
    info: facts about the experiment shown in the report (condition numbers, saturation ...).
    clean_tau: (N, n) N m, the identification recording's torque before its measurement noise, when
    the simulation adds the noise to the recorded torque only (closed loop), else None.
    """

    recording: Recording
    validation: Recording | None = None
    excitation: object | None = None
    info: dict = field(default_factory=dict)
    clean_tau: np.ndarray | None = None


def split_recording(rec: Recording, holdout_fraction: float) -> tuple[Recording, Recording | None]:
    """(identification, held out): the recording's first 1 - holdout_fraction and its last
    holdout_fraction of samples (None for 0), each filtered on its own by the regressions."""
    if holdout_fraction <= 0:
        return rec, None
    k = int(round((1.0 - holdout_fraction) * rec.t.size))
    return (Recording(rec.t[:k], rec.q[:k], rec.tau[:k]), Recording(rec.t[k:], rec.q[k:], rec.tau[k:]))


def _check_held_out(held_out: Recording, fraction: float, n_joints: int, pp, where: str) -> None:
    """StudyError when the held-out part is too short for one inverse dynamic row (its own filters'
    edges are dropped too), naming the fraction that would give some."""
    span = float(held_out.t[-1] - held_out.t[0])
    need = sizing.minimum_duration(held_out.h, n_joints, n_joints, ("inverse_dynamic",), pp.lowpass_cutoff_hz,
                                   pp.decimation)["inverse_dynamic"]
    if span < need * (1.0 + 1e-9):
        total = span / fraction
        raise StudyError(f"{where}: holdout_fraction = {fraction:g} keeps {span:.3g} s out, too short for one "
                         f"inverse dynamic row once its filters' edges are dropped (it needs more than {need:.3g} s): "
                         f"raise it to at least {min(0.5, 1.05 * need / total):.2g}"
                         + (" or record longer." if 1.05 * need / total > 0.5 else "."))


def acquire(cfg: StudyConfig, model: RobotModel, rng: np.random.Generator, excitation=None) -> StudyData:
    """Simulate (open or closed loop) and measure, or read the study's recording. ``excitation``:
    the identification run's designed excitation (:mod:`boundid.studies.excitation`: a torque law for
    the open-loop experiment, a trajectory for the others); None: the experiment's own."""
    exp = cfg.experiment
    if exp.source == "measured":
        m = exp.measured
        rec = read_recording(m.file, m.time, m.q, m.tau, tau_file=m.tau_file, sample_period_s=m.sample_period_s,
                             angle_unit=m.angle_unit, time_unit=m.time_unit, transmission=m.transmission)
        if rec.n_joints != model.n_joints:
            raise StudyError(f"{cfg.file}: the recording has {rec.n_joints} joints, the {model.name} model "
                             f"{model.n_joints}; map one q and one tau column per joint.")
        rec, held_out = split_recording(rec, m.holdout_fraction)
        pp, where = cfg.preprocessing, f"{cfg.file}: the recording {m.file.name}"
        if "inverse_dynamic" in cfg.regressions:
            sizing.check_cutoff(rec.h, pp.lowpass_cutoff_hz, pp.decimation, f"{where} at h = {rec.h:g} s")
        sizing.check_budget(rec.t.size, rec.n_joints, model.p, len(cfg.regressions), where)
        sizing.check_length(float(rec.t[-1] - rec.t[0]), rec.h, model.n_joints, model.p, cfg.regressions,
                            pp.lowpass_cutoff_hz, pp.decimation, f"{where} ({rec.t.size} samples)")
        info = {"source": " + ".join(str(f) for f in (m.file, m.tau_file) if f)}
        if held_out is not None:
            info["held out"] = (f"the last {100 * m.holdout_fraction:g} % of the recording "
                                f"({held_out.t[0]:.4g}-{held_out.t[-1]:.4g} s), kept out of identification")
            _check_held_out(held_out, m.holdout_fraction, model.n_joints, pp, where)
        return StudyData(recording=rec, validation=held_out, info=info)
    if exp.control == "open_loop":
        return _open_loop(cfg, model, rng, excitation)
    if exp.control == "tracking":
        return _tracking(cfg, model, rng, excitation)
    recording, validation, info, clean_tau = closed_loop_data(cfg, model, rng, excitation)
    return StudyData(recording=recording, validation=validation, info=info, clean_tau=clean_tau)


def _open_loop(cfg: StudyConfig, model: RobotModel, rng: np.random.Generator, excitation=None) -> StudyData:
    exp = cfg.experiment
    if "open_loop" not in model.experiments:
        raise StudyError(f"{cfg.file}: experiment.control = 'open_loop' drives the paper's 2-joint torques "
                         f"(31)-(32), which the {cfg.robot} model does not support; its experiments: "
                         f"{', '.join(model.experiments) or 'none (use measured data)'}.")
    excitation = RampedMultisine.direct_drive_paper() if excitation is None else excitation
    traj = simulate_open_loop(model, excitation, exp.duration_s, exp.sample_period_s,
                              coulomb_width=exp.coulomb_width_rad_s)
    meas = measure(traj, exp.encoder_counts_per_rev, exp.torque_noise, rng)
    return StudyData(recording=Recording(t=meas.t, q=meas.q, tau=meas.tau), excitation=excitation,
                     info={"torque outliers": int(meas.info["outliers"].sum())})


def tracking_config(cfg: StudyConfig):
    """The tracking experiment (:class:`boundid.experiments.tracking.TrackingConfig`) of the study's [experiment]."""
    from boundid.experiments.tracking import TrackingConfig

    exp = cfg.experiment
    return TrackingConfig(duration_s=exp.duration_s, validation_duration_s=exp.validation_duration_s,
                          fs_hz=1.0 / exp.sample_period_s, counts_per_rev=exp.encoder_counts_per_rev or 65536,
                          coulomb_width=exp.coulomb_width_rad_s, torque_noise=exp.torque_noise,
                          **exp.options)  # checked against registry.tracking_options() when the study was read


def _tracking(cfg: StudyConfig, model: RobotModel, rng: np.random.Generator, trajectory=None) -> StudyData:
    """The tracking experiment of a serial arm (:mod:`boundid.experiments.tracking`)."""
    from boundid.experiments.tracking import tracking_experiment

    if "tracking" not in model.experiments:
        raise StudyError(f"{cfg.file}: experiment.control = 'tracking' needs an arm with joint limits (a URDF robot); "
                         f"the {cfg.robot} model's experiments: {', '.join(model.experiments) or 'none'}.")
    recs, info = tracking_experiment(model, rng, tracking_config(cfg), trajectory)

    def recording(name: str) -> Recording | None:
        r = recs.get(name)
        return None if r is None else Recording(t=r.run.t, q=r.run.q_meas, tau=r.tau_meas)

    return StudyData(recording=recording("identification"), validation=recording("validation"), info=info,
                     clean_tau=recs["identification"].run.tau)

