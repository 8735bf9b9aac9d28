"""The closed-loop experiment of [H4Paper]: PI control at 1 kHz on the "truth" robot."""

from __future__ import annotations

import numpy as np

from boundid.errors import StudyError
from boundid.experiments.h4_pipeline import H4ExperimentConfig, simulate_h4_experiment
from boundid.experiments.recording import Recording
from boundid.models import RobotModel
from boundid.studies.config import StudyConfig


def h4_config(cfg: StudyConfig) -> H4ExperimentConfig:
    """The simulated H4 experiment of the study's [experiment] table."""
    exp = cfg.experiment
    return H4ExperimentConfig(
        duration_s=exp.duration_s, validation_duration_s=exp.validation_duration_s,
        fs_hz=1.0 / exp.sample_period_s, counts_per_rev=exp.encoder_counts_per_rev or 65536,
        coulomb_width=exp.coulomb_width_rad_s, structural=exp.structural_error, torque_noise=exp.torque_noise,
        **exp.options,  # checked against registry.closed_loop_options() when the study was read
    )


def closed_loop_data(cfg: StudyConfig, model: RobotModel, rng: np.random.Generator,
                     trajectory=None) -> tuple[Recording, Recording, dict, np.ndarray]:
    """Identification and validation recordings (encoder angles, measured torques) of the H4, the
    experiment's facts for the report (:class:`boundid.studies.data.StudyData` holds them) and the
    identification run's torque before the measurement noise (N, 4) N m: the noise is added to the
    recorded torque only, so a new draw of it is a new draw of the experiment's noise.
    ``trajectory``: the identification run's (designed) trajectory; None draws one."""
    exp = cfg.experiment
    if "closed_loop" not in model.experiments:
        raise StudyError(f"{cfg.file}: experiment.control = 'closed_loop' is the H4 paper's experiment, which the "
                         f"{cfg.robot} model does not support; its experiments: "
                         f"{', '.join(model.experiments) or 'none (use measured data)'}.")
    if exp.validation_duration_s <= 0:
        raise StudyError(f"{cfg.file}: experiment.validation_duration_s must be > 0 for the cross-validation "
                         "trajectory of the closed-loop experiment.")
    recs, info = simulate_h4_experiment(rng, h4_config(cfg), model, trajectory)

    def recording(name: str) -> Recording:
        r = recs[name]
        return Recording(t=r.run.t, q=r.run.q_meas, tau=r.tau_meas)

    return recording("identification"), recording("validation"), info, recs["identification"].run.tau
