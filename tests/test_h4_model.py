"""H4 robot: kinematics (IK, Newton FK, J, Jdot) and the 14-parameter dynamic model."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from boundid.errors import InputError, UnreachablePoseError
from boundid.models import H4Geometry, H4Robot, H4Structural, H4Truth
from boundid.models import _h4_kernels as kern


@pytest.fixture(scope="module")
def robot():
    return H4Robot()


def _grid(robot, n=4):
    g = robot.geometry
    axes = [np.linspace(lo, hi, n) for lo, hi in zip(g.workspace_low, g.workspace_high, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 4)


def _random_states(robot, n, seed=0):
    rng = np.random.default_rng(seed)
    g = robot.geometry
    x = rng.uniform(g.workspace_low, g.workspace_high, (n, 4))
    return robot.inverse_kinematics(x), rng.normal(0, 1.0, (n, 4)), rng.normal(0, 5.0, (n, 4))


def test_ik_then_fk_returns_the_pose_over_the_workspace_grid(robot):
    """Reference: the pose itself. FK (Newton, eq. 10) of IK(x) must give x back to 1e-10."""
    x = _grid(robot)
    q = robot.inverse_kinematics(x)
    assert np.max(np.abs(robot.forward_kinematics(q) - x)) < 1e-10
    # the closure constraints |A_i - B_i| = l hold exactly (independent check of the IK formula)
    A, _ = robot.attachments(x)
    B, _ = robot.elbows(q)
    assert np.allclose(np.linalg.norm(A - B, axis=2), robot.geometry.l, atol=1e-12)
    # the compiled Newton kernel used by the simulation agrees with the numpy one
    geo = robot._geo
    xk = np.array([kern._fk1(qi, np.asarray(robot.geometry.home), *geo, 1e-12, 30)[0] for qi in q[:20]])
    assert np.max(np.abs(xk - x[:20])) < 1e-10
    assert robot.condition(x).max() < 50.0  # design note: cond(J) "below about 40" (42 at the box corners)


def test_jacobian_matches_finite_differences_of_fk(robot):
    """Reference: central finite differences of the forward model, dx/dq_j, to 1e-6."""
    x = _grid(robot, 3)
    q = robot.inverse_kinematics(x)
    J = robot.jacobian(x)
    eps = 1e-6
    for j in range(4):
        dq = np.zeros(4)
        dq[j] = eps
        fd = (robot.forward_kinematics(q + dq, x) - robot.forward_kinematics(q - dq, x)) / (2 * eps)
        assert np.max(np.abs(J[:, :, j] - fd)) < 1e-6


def test_analytic_jdot_agrees_with_central_differences(robot):
    """Reference: central differences of J, along the motion at one instant and along a sampled path."""
    q, qd, _ = _random_states(robot, 30, seed=1)
    x = robot.forward_kinematics(q)
    Jd = robot.jacobian_dot(x, qd)
    h = 1e-5
    fd = (robot.jacobian(robot.forward_kinematics(q + h * qd, x))
          - robot.jacobian(robot.forward_kinematics(q - h * qd, x))) / (2 * h)
    assert np.max(np.abs(Jd - fd)) < 1e-6 * max(1.0, np.abs(Jd).max())
    # the paper's version: central differences in time along a trajectory sampled at 1 kHz
    t = np.arange(0, 1.0, 1e-3)
    w = 2 * np.pi * 0.7
    qt = q[0] + 0.2 * np.sin(w * t)[:, None] * np.array([1.0, -0.5, 0.8, 0.3])
    qdt = 0.2 * w * np.cos(w * t)[:, None] * np.array([1.0, -0.5, 0.8, 0.3])
    xt = robot.forward_kinematics(qt)
    Jc = robot.jacobian_dot_central(xt, 1e-3)
    Ja = robot.jacobian_dot(xt, qdt)
    assert np.max(np.abs(Jc[1:-1] - Ja[1:-1])) < 1e-4 * np.abs(Ja).max()


def _independent_torque(robot, q, qd, qdd, theta, g=9.81):
    """Eq. (14) in joint-space inertia form, written here from J and Jdot only."""
    x = robot.forward_kinematics(q)
    J, Jd = robot.jacobian(x), robot.jacobian_dot(x, qd)
    Mx = np.diag([theta[4]] * 3 + [theta[5]])
    M = np.diag(theta[:4]) + np.einsum("nki,kl,nlj->nij", J, Mx, J)
    G = np.array([0, 0, -g, 0])
    b = np.einsum("nki,kl,nl->ni", J, Mx, np.einsum("nij,nj->ni", Jd, qd) - G)
    b += theta[6:10] * qd + theta[10:] * np.sign(qd)
    return np.einsum("nij,nj->ni", M, qdd) + b, M, b


def test_regressor_times_theta_equals_independent_dynamics(robot):
    """Reference: M(q) qdd + b(q, qd) written in the test; also checks the compiled mass matrix and bias."""
    q, qd, qdd = _random_states(robot, 50, seed=2)
    tau, M, b = _independent_torque(robot, q, qd, qdd, robot.theta_true)
    assert np.allclose(robot.regressor(q, qd, qdd) @ robot.theta_true, tau, atol=1e-10, rtol=0)
    assert np.allclose(robot.mass_matrix(q), M, atol=1e-12)
    assert np.allclose(robot.bias_torque(q, qd), b, atol=1e-10)
    qdd_fd = robot.forward_dynamics(q, qd, tau)
    assert np.allclose(qdd_fd, qdd, atol=1e-8)
    assert robot.regressor(q[0], qd[0], qdd[0]).shape == (4, 14)


def test_momentum_and_remainder_regressors(robot):
    """Reference: d/dt(Ya theta) by central differences along a path, + Yb theta = Y theta."""
    q0, _, _ = _random_states(robot, 1, seed=3)
    ph = np.arange(4)

    def path(t):
        return (q0[0] + 0.2 * np.sin(2 * t + ph), 0.4 * np.cos(2 * t + ph), -0.8 * np.sin(2 * t + ph))

    th, h = robot.theta_true, 1e-5
    for t0 in (0.1, 0.7, 1.9):
        dp = (robot.momentum_regressor(*path(t0 + h)[:2]) - robot.momentum_regressor(*path(t0 - h)[:2])) @ th / (2 * h)
        lhs = dp + robot.remainder_regressor(*path(t0)[:2]) @ th
        assert np.allclose(lhs, robot.regressor(*path(t0)) @ th, atol=1e-8)
    q, qd, _ = _random_states(robot, 5, seed=4)
    p = robot.momentum_regressor(q, qd) @ th
    assert np.allclose(p, np.einsum("nij,nj->ni", robot.mass_matrix(q), qd), atol=1e-12)


@pytest.mark.parametrize("model", [H4Robot(), H4Truth(structural=2.0)], ids=["model", "truth"])
def test_energy_balance_along_a_simulated_trajectory(model):
    """Reference: integral of qd^T tau - friction power (scipy solve_ivp) equals H(T) - H(0).

    Checks mass matrix, bias and energy together; for the truth variant also the structural terms.
    Coulomb friction is set to zero so that the ODE is smooth (its power is checked separately).
    """
    th = model.theta_true.copy()
    th[10:] = 0.0
    q0 = model.inverse_kinematics(np.asarray(model.geometry.home))
    hold = model.bias_torque(q0, np.zeros(4), th)
    amp = np.array([1.0, -1.0, 0.5, 0.2])

    def f(t, y):
        q, qd = y[:4], y[4:8]
        tau = hold + amp * np.sin(6 * t)
        power = qd @ tau - model.friction_power_regressor(qd) @ th
        return np.concatenate([qd, model.forward_dynamics(q, qd, tau, th), [power]])

    y0 = np.concatenate([q0, np.zeros(4), [0.0]])
    yT = solve_ivp(f, (0, 0.8), y0, method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
    dH = model.energy(yT[:4], yT[4:8], th) - model.energy(q0, np.zeros(4), th)
    assert abs(dH) > 1e-2  # something happened
    assert abs(dH - yT[-1]) < 1e-8
    # friction power regressor: qd^T (Fv qd + Fs sign qd)
    qd = np.array([0.3, -0.2, 0.0, 1.1])
    fr = model.theta_true[6:10] * qd + model.theta_true[10:] * np.sign(qd)
    assert np.isclose(model.friction_power_regressor(qd) @ model.theta_true, qd @ fr)


def test_truth_adds_bounded_structural_torque(robot):
    """Reference: the identification model; the truth differs by a bounded, scale-proportional amount."""
    q, qd, qdd = _random_states(robot, 40, seed=5)
    tau0 = robot.inverse_dynamics(q, qd, qdd)
    d1 = H4Truth(structural=1.0).inverse_dynamics(q, qd, qdd) - tau0
    d2 = H4Truth(structural=2.0).inverse_dynamics(q, qd, qdd) - tau0
    assert np.allclose(H4Truth(structural=0.0).inverse_dynamics(q, qd, qdd), tau0, atol=1e-12)
    assert 0.1 < np.abs(d1).max() < 2.25
    assert np.allclose(d2, 2 * d1, atol=1e-9)  # linear in the masses and the ripple amplitude


def test_unreachable_and_singular_poses_raise(robot):
    """Reference: the closed-form reachability condition |k| <= hypot(a, b) and cond(J) -> inf at its edge."""
    with pytest.raises(UnreachablePoseError, match="unreachable"):
        robot.inverse_kinematics([0.0, 0.0, -1.5, 0.0])
    with pytest.raises(UnreachablePoseError, match="did not converge"):
        robot.forward_kinematics([3.0, 3.0, 3.0, 3.0])
    # walk down the z axis to the edge of the reachable set (arm and forearm aligned)
    lo, hi = -0.9, -1.3
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        ok = np.all(np.abs(robot._ik(np.array([[0, 0, mid, 0.0]]))[1]) <= 1)
        lo, hi = (mid, hi) if ok else (lo, mid)
    edge = np.array([0.0, 0.0, lo, 0.0])
    q_edge = robot.inverse_kinematics(edge)  # still reachable
    assert np.all(np.isfinite(q_edge))
    with pytest.raises(UnreachablePoseError, match="singularity"):
        robot.jacobian(edge)
    with pytest.raises(UnreachablePoseError):
        robot.mass_matrix([3.0, 3.0, 3.0, 3.0])


def test_bad_inputs_raise_input_error(robot):
    """Reference: the documented contract (named errors for wrong shapes and values)."""
    with pytest.raises(InputError):
        H4Geometry(L=-0.3)
    with pytest.raises(InputError):
        H4Geometry(home=(0.0, 0.0, -2.0, 0.0))
    with pytest.raises(InputError):
        H4Structural(rod_mass=-1.0)
    with pytest.raises(InputError):
        robot.inverse_kinematics(np.zeros(3))
    with pytest.raises(InputError):
        robot.regressor(np.zeros((2, 4)), np.zeros((3, 4)), np.zeros((2, 4)))
    assert np.isnan(robot.theta_prior[6:]).all() and robot.theta_prior[4] == 1.0
    assert len(robot.param_names) == 14 and robot.param_names[10] == "Fs1"
