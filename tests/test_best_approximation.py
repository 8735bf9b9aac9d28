"""The identification model's best approximation of the simulated H4 (the second truth)."""

import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.errors import InputError
from boundid.experiments.best_approximation import best_approximation, exact_rows, fit
from boundid.experiments.trajectories import exciting_trajectory
from boundid.models import H4Robot, H4Truth


@pytest.fixture(scope="module")
def robot():
    return H4Robot()


@pytest.fixture(scope="module")
def rows(robot):
    """Exact rows of the model on the truth's torques along one seeded 20 s exciting trajectory (100 Hz)."""
    traj = exciting_trajectory(robot, np.random.default_rng(5), duration=20.0, fast_period=1.0)
    t = np.arange(0.0, traj.duration, 0.01)
    return exact_rows(H4Truth(), robot, *traj.evaluate(t))


def test_minimax_fit_is_the_minimiser_of_the_max_residual(robot, rows):
    """Reference: scipy.optimize.linprog on the textbook Chebyshev LP (min t, -t <= y - W theta <= t),
    and the truth's own residual, which no minimiser may exceed. The least-squares fit has the
    smaller rms residual, the minimax fit the smaller maximum."""
    W, y = rows
    mm, ls = fit(W, y, "minimax"), fit(W, y, "least_squares")
    truth_max = np.abs(y - W @ robot.theta_true).max()
    assert truth_max > 0.02  # the model cannot represent the truth exactly
    assert mm.max_residual <= truth_max + 1e-9
    assert mm.max_residual <= ls.max_residual + 1e-9 and ls.rms_residual <= mm.rms_residual + 1e-12
    n, p = W.shape
    ones = np.ones((n, 1))
    res = linprog(np.r_[np.zeros(p), 1.0], A_ub=np.block([[W, -ones], [-W, -ones]]), b_ub=np.r_[y, -y],
                  bounds=[(None, None)] * p + [(0, None)], method="highs")
    assert res.status == 0
    assert np.isclose(mm.max_residual, res.fun, rtol=1e-7)
    assert np.isclose(np.abs(y - W @ mm.theta).max(), mm.max_residual, rtol=0, atol=1e-12)


def test_without_structural_error_the_best_approximation_is_the_truth(robot):
    """Reference: theta_true itself. With no structure the model is exact, so the fit returns
    Table I to 1e-8 (relative) with a residual at rounding level; the same seed gives the same fit."""
    truth = H4Truth(structural=0.0)
    a = best_approximation(truth, robot, np.random.default_rng(2), duration_s=10.0, segment_s=10.0, fs_hz=50.0)
    assert np.allclose(a.theta, robot.theta_true, rtol=1e-8, atol=1e-12)
    assert a.max_residual < 1e-9 and a.rms_residual <= a.max_residual
    b = best_approximation(truth, robot, np.random.default_rng(2), duration_s=10.0, segment_s=10.0, fs_hz=50.0)
    assert np.array_equal(a.theta, b.theta) and a.max_residual == b.max_residual


def test_best_approximation_of_the_structural_truth_and_its_bad_inputs(robot):
    """Reference: the truth's own max residual on the same rows (the best approximation's is smaller)
    and the motor-inertia share in theta_true (the fit's Imot stays near Table I, not near the rotor)."""
    truth = H4Truth()
    a = best_approximation(truth, robot, np.random.default_rng(3), duration_s=20.0, fs_hz=50.0)
    W, y = exact_rows(truth, robot, *exciting_trajectory(robot, np.random.default_rng(3), duration=20.0,
                                                         fast_period=1.0).evaluate(np.arange(0.0, 20.0, 0.02)))
    assert a.max_residual <= np.abs(y - W @ robot.theta_true).max() + 1e-9
    rotor = truth.body_parameters()[:4]
    assert np.all(np.abs(a.theta[:4] - robot.theta_true[:4]) < np.abs(a.theta[:4] - rotor))
    with pytest.raises(InputError, match="criterion"):
        fit(W, y, "huber")
    with pytest.raises(InputError, match="segment_s"):
        best_approximation(truth, robot, np.random.default_rng(0), duration_s=5.0, segment_s=10.0)
