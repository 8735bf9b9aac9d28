"""The identification model's best approximation of a simulated robot (the "second truth").

When the simulated robot holds more than the identification model can represent (the H4's arm
weight, forearm rotation, cogging), no parameter vector reproduces its torques exactly. Then two
truths exist and a study should name which one it compares with:

1. the simulator's parameters, ``truth_robot.theta_true`` (for the H4: Table I, with the arms' and
   rods' motor-inertia share in Imot);
2. the model's best approximation: the theta that fits the simulated robot's exact torques best
   over a long, exciting motion, with its maximum residual (the smallest error bound any theta
   can meet: the structural-error floor of the model).

Criterion: by default the minimax (Chebyshev) fit, min_theta max_k |tau_k - w_k^T theta|, one LP
(the consistency LP of :meth:`boundid.sets.Polytope.consistency`). It is the natural best
approximation for a bounded-error study: its maximum residual is the smallest e_max with which
the noise-free data are consistent, and the truth of a guaranteed estimator is exactly a point
that keeps every residual within the bound. ``criterion = "least_squares"`` gives the ordinary
least-squares fit (smallest rms residual) for comparison.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from boundid.errors import InputError
from boundid.experiments.trajectories import exciting_trajectory
from boundid.sets import Polytope

CRITERIA = ("minimax", "least_squares")


class BestApproximation(NamedTuple):
    """theta (p,) of the model; max_residual and rms_residual (torque units, N m) of the fit."""

    theta: np.ndarray
    max_residual: float
    rms_residual: float


def exact_rows(truth_robot, model, q, qd, qdd, coulomb_width: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free rows of ``model``'s inverse dynamics on ``truth_robot``'s torques.

    q, qd, qdd : (N, n) exact joint states. Returns W (N n, p) = model.regressor, sample-major, and
    y (N n,) = truth M(q) qdd + b(q, qd) (Coulomb smoothed as tanh(qd / coulomb_width) if > 0).
    """
    M = truth_robot.mass_matrix(q)
    tau = np.einsum("nij,nj->ni", M, qdd) + truth_robot.bias_torque(q, qd, coulomb_width=coulomb_width)
    return model.regressor(q, qd, qdd).reshape(-1, model.p), tau.reshape(-1)


def fit(W: np.ndarray, y: np.ndarray, criterion: str = "minimax") -> BestApproximation:
    """Best theta for rows (W (N, p), y (N,)) by ``criterion`` ("minimax" LP or "least_squares")."""
    if criterion not in CRITERIA:
        raise InputError(f"criterion must be one of {CRITERIA}, got {criterion!r}.")
    if criterion == "minimax":
        theta = Polytope.from_strips(W, y, 1.0).consistency().theta
    else:
        theta = np.linalg.lstsq(W, y, rcond=None)[0]
    r = y - W @ theta
    return BestApproximation(theta, float(np.abs(r).max()), float(np.sqrt(np.mean(r**2))))


def best_approximation(truth_robot, model, rng: np.random.Generator, duration_s: float = 120.0,
                       segment_s: float = 20.0, fs_hz: float = 200.0, coulomb_width: float = 0.0,
                       criterion: str = "minimax", slow_fraction: float = 0.4,
                       fast_period: float = 1.0) -> BestApproximation:
    """The model's best approximation of ``truth_robot`` on exact, noise-free data.

    Motion: ``duration_s / segment_s`` independent exciting trajectories (each a slow and a
    repeated fast segment, see :func:`exciting_trajectory`, drawn from ``rng``), sampled at
    ``fs_hz`` with their exact q, qd, qdd: no encoder, filter or noise, so the residual is the
    model's structural error alone. coulomb_width : rad/s, the truth's Coulomb smoothing (0 =
    the sign of the identification model; pass the simulation's width to include its smoothing).
    Deterministic for a given ``rng`` state. Returns (theta, max_residual, rms_residual).
    """
    if truth_robot.n_joints != model.n_joints:
        raise InputError(f"truth_robot has {truth_robot.n_joints} joints, model {model.n_joints}.")
    if not (duration_s > 0 and 0 < segment_s <= duration_s and fs_hz > 0 and coulomb_width >= 0):
        raise InputError("need duration_s > 0, 0 < segment_s <= duration_s (s), fs_hz > 0 and "
                         f"coulomb_width >= 0; got {duration_s}, {segment_s}, {fs_hz}, {coulomb_width}.")
    n_seg = int(round(duration_s / segment_s))
    t = np.arange(0.0, segment_s, 1.0 / fs_hz)
    Ws, ys = [], []
    for _ in range(n_seg):
        traj = exciting_trajectory(model, rng, duration=segment_s, slow_fraction=slow_fraction,
                                   fast_period=fast_period)
        W, y = exact_rows(truth_robot, model, *traj.evaluate(t), coulomb_width=coulomb_width)
        Ws.append(W)
        ys.append(y)
    return fit(np.vstack(Ws), np.concatenate(ys), criterion)
