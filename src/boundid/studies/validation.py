"""Validation of identified parameters on data they were not fitted to (or by re-simulation).

- open loop ([DirectDrivePaper]): re-simulate the robot with each identified theta under the same torques
  and compare the joint positions with the measured ones;
- cross-validation trajectory ([H4Paper] eq. 37): predict the torque of a different experiment,
  with the bounds of a set-membership estimate S, [-h_S(-w), h_S(w)] (h_S the support function:
  for an ellipsoid w^T theta_hat +- sqrt(w^T S w), eq. 37; the same formula for a set of any
  family), and the statistical 95 % prediction band w^T theta_hat +- 1.96 sqrt(w^T Cov w + sigma^2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boundid.errors import RUN_FAILURES
from boundid.estimators import Estimate
from boundid.experiments.simulation import simulate_open_loop
from boundid.models import RobotModel
from boundid.studies.config import StudyConfig
from boundid.studies.data import StudyData
from boundid.studies.regressions import inverse_dynamic_rows


@dataclass
class Resimulation:
    """Open-loop re-simulation with identified parameters. q: (N, n) rad, or None with the reason."""

    label: str
    q: np.ndarray | None
    rms_error_rad: np.ndarray | None
    failure: str | None = None


@dataclass
class TorqueBand:
    """Predicted torque on the validation trajectory, (N, n) N m each: the prediction
    w^T theta_hat and the band [lower, upper] around it; ``kind`` the estimate's."""

    label: str
    center: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    kind: str

    @property
    def half_width(self) -> np.ndarray:
        """Half the band's width (N, n) N m."""
        return 0.5 * (self.upper - self.lower)

    def outside_fraction(self, measured: np.ndarray) -> float:
        return float(np.mean((measured < self.lower) | (measured > self.upper)))


def _mass_matrix_pd(model: RobotModel, q: np.ndarray, theta: np.ndarray) -> bool:
    """Whether M(q, theta) is positive definite at every sampled q (physically consistent theta)."""
    return bool(np.all(np.linalg.eigvalsh(model.mass_matrix(q[::10], theta)) > 0))


def resimulate(cfg: StudyConfig, model: RobotModel, data: StudyData, label: str, theta: np.ndarray) -> Resimulation:
    exp, rec = cfg.experiment, data.recording
    try:
        if not _mass_matrix_pd(model, rec.q, theta):
            return Resimulation(label, None, None, "M(q) is not positive definite along the trajectory: "
                                                   "these parameters describe no physical robot")
        traj = simulate_open_loop(model, data.excitation, exp.duration_s, exp.sample_period_s, theta=theta,
                                  coulomb_width=exp.coulomb_width_rad_s, rtol=1e-8, atol=1e-8)
    except RUN_FAILURES as exc:  # e.g. a "math domain error" when the identified dynamics diverge
        return Resimulation(label, None, None, f"simulation failed: {type(exc).__name__}: {exc}")
    rms = np.sqrt(np.mean((traj.q - rec.q) ** 2, axis=0))
    return Resimulation(label, traj.q, rms)


def torque_bands(W: np.ndarray, n_joints: int, estimates: dict[str, Estimate],
                 joint: np.ndarray) -> dict[str, TorqueBand]:
    """[H4Paper] eq. 37 bounds [-h_S(-w), h_S(w)] of each row w of W for set-membership estimates
    (guaranteed or unverified, any family), 95 % prediction bands w^T c +- 1.96 sqrt(w^T Cov w +
    noise variance) for statistical ones; point estimates get none."""
    bands = {}
    for label, est in estimates.items():
        center = W @ est.center
        if est.set_membership:
            upper = np.array([est.set.support(w) for w in W])
            lower = np.array([-est.set.support(-w) for w in W])
        elif est.statistics is not None:
            var = np.einsum("ij,jk,ik->i", W, est.statistics.cov, W)
            half = 1.96 * np.sqrt(var + est.statistics.row_noise_variance(joint))
            lower, upper = center - half, center + half
        else:
            continue
        bands[label] = TorqueBand(label, *(a.reshape(-1, n_joints) for a in (center, lower, upper)), est.kind)
    return bands


def validate_study(cfg: StudyConfig, model: RobotModel, data: StudyData,
                   estimates: dict[tuple[str, str], Estimate]) -> dict:
    out: dict = {}
    if data.excitation is not None:
        out["resimulation"] = [resimulate(cfg, model, data, f"{lab} / {rn}", est.center)
                               for (lab, rn), est in estimates.items()]
    if data.validation is not None:

        reg = inverse_dynamic_rows(model, data.validation, cfg.preprocessing)
        ests = {lab: e for (lab, rn), e in estimates.items() if rn == "inverse_dynamic"}
        out["validation_regression"] = reg
        out["torque_bands"] = torque_bands(reg.W, model.n_joints, ests, reg.joint)
    return out
