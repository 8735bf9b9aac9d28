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
    xb, ok = kern.fk_batch(q, np.tile(np.asarray(robot.geometry.home), (len(q), 1)), *geo, 1e-12, 30)
    assert ok.all() and np.max(np.abs(xb - x)) < 1e-10     # the batch used by workspace_excursion
    assert robot.condition(x).max() < 50.0  # docs/models.md: cond(J) "below about 40" (42 at the box corners)


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


@pytest.mark.parametrize("model", [H4Robot(), H4Truth(structural=1.5)], ids=["model", "truth"])
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


def test_truth_differs_from_the_model_by_a_bounded_structural_torque(robot):
    """Reference: the identification model at the truth's theta_true (Table I); the truth differs by
    a torque linear in the structural scale, zero without structure, small beside the 2.25 N m bound."""
    q, qd, qdd = _random_states(robot, 40, seed=5)
    tau0 = robot.inverse_dynamics(q, qd, qdd)
    d1 = H4Truth(structural=1.0).inverse_dynamics(q, qd, qdd) - tau0
    d_half = H4Truth(structural=0.5).inverse_dynamics(q, qd, qdd) - tau0
    assert np.allclose(H4Truth(structural=0.0).inverse_dynamics(q, qd, qdd), tau0, atol=1e-12)
    assert 0.02 < np.abs(d1).max() < 0.5 * 2.25
    assert np.allclose(d1, 2 * d_half, atol=1e-9)  # linear in the masses and the ripple amplitude


def _bodies(truth, q):
    """Point masses (positions (K, 3), masses (K,)) of the arms, elbows, counter-masses and rods of
    ``truth`` at angles q (4,), rods and bars by 3-point Gauss-Legendre quadrature along them
    (exact for the quadratic integrands of kinetic and potential energy), and the nacelle pose."""
    s, geo = truth.structural, truth.geometry
    nodes, weights = np.polynomial.legendre.leggauss(3)
    nodes, weights = 0.5 * (nodes + 1), 0.5 * weights
    x = truth.forward_kinematics(q)
    A = truth.attachments(x[None])[0][0]
    B = truth.elbows(q[None])[0][0]
    pts, mass = [], []
    for i in range(4):
        arm = B[i] - geo.P[i]
        pts += [geo.P[i] + u * arm for u in nodes] + [B[i], geo.P[i] - s.counter_distance / geo.L * arm]
        mass += list(s.link_mass * weights) + [s.elbow_mass, s.counter_mass]
        pts += [B[i] + u * (A[i] - B[i]) for u in nodes]
        mass += list(s.rod_mass * weights)
    return np.array(pts), np.array(mass), x


def _fd(f, q, eps=1e-5):
    """Central-difference derivative of f(q) (array) with respect to each q_j, stacked last."""
    cols = []
    for j in range(4):
        dq = np.zeros(4)
        dq[j] = eps
        cols.append((f(q + dq) - f(q - dq)) / (2 * eps))
    return np.stack(cols, axis=-1)


def test_truth_built_body_by_body_and_the_represented_share():
    """Reference: the simulated robot assembled from its bodies, independently of the kernel.

    Rotors and nacelle body = theta_true (Table I) minus ``represented_share``; arms, elbows,
    counter-masses and rods as point masses (Gauss quadrature along bars and rods); their point
    Jacobians and potential gradient by central finite differences of the forward model. Checks
    (1) the compiled inertia and gravity torque against it, and (2) that what the model at
    theta_true misses holds nothing of motor-inertia or nacelle form: exactly the rods' own
    rotation, -(m/6) sum_i Jrel_i^T Jrel_i with Jrel_i = d(A_i - B_i)/dq (a uniform rod has a third
    of the two-end-mass inertia about its centre) and the unbalanced weight. A wrong share (say
    the arm's m L^2 / 2 instead of m L^2 / 3) leaves a diagonal term and fails (2).
    """
    truth = H4Truth()
    model = H4Robot()
    s, g = truth.structural, truth.g
    body = truth.body_parameters()
    q_all, _, _ = _random_states(model, 4, seed=11)
    for q in q_all:
        pts, mass, _ = _bodies(truth, q)
        Jp = _fd(lambda qq: _bodies(truth, qq)[0], q)  # (K, 3, 4)
        Jx = _fd(lambda qq: truth.forward_kinematics(qq), q)  # (4, 4)
        M = np.diag(body[:4]) + body[4] * Jx[:3].T @ Jx[:3] + body[5] * np.outer(Jx[3], Jx[3])
        M += np.einsum("k,kai,kaj->ij", mass, Jp, Jp)

        def potential(qq):
            p, m, x = _bodies(truth, qq)
            cog = s.ripple_amplitude / s.ripple_periods * np.cos(s.ripple_periods * qq).sum()
            return np.array(g * (m @ p[:, 2] + body[4] * x[2]) + cog)

        grav = _fd(potential, q)
        assert np.allclose(truth.mass_matrix(q), M, atol=1e-8)
        assert np.allclose(truth.bias_torque(q, np.zeros(4)), grav, atol=1e-8)
        # (2) beyond the model at theta_true: only the rods' rotation and the unbalanced weight
        Jrel = _fd(lambda qq: truth.attachments(truth.forward_kinematics(qq)[None])[0][0]
                   - truth.elbows(qq[None])[0][0], q)  # (4, 3, 4)
        dM = truth.mass_matrix(q) - model.mass_matrix(q)
        assert np.allclose(dM, -s.rod_mass / 6 * np.einsum("iak,ial->kl", Jrel, Jrel), atol=1e-8)
        unbalanced = (s.arm_moment(truth.geometry.L) + 0.5 * s.rod_mass * truth.geometry.L) * g
        cog = -s.ripple_amplitude * np.sin(s.ripple_periods * q)
        dB = truth.elbows(q[None])[1][0][:, 2] / truth.geometry.L  # d(z of the arm's unit direction)/dq_i
        assert np.allclose(truth.bias_torque(q, np.zeros(4)) - model.bias_torque(q, np.zeros(4)),
                           unbalanced * dB + cog, atol=1e-8)


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
    with pytest.raises(InputError, match="Imot2 = .* not physical"):
        H4Truth(structural=H4Structural(link_mass=0.5))  # the arm alone outweighs Table I's Imot2
    with pytest.raises(InputError):
        robot.inverse_kinematics(np.zeros(3))
    with pytest.raises(InputError):
        robot.regressor(np.zeros((2, 4)), np.zeros((3, 4)), np.zeros((2, 4)))
    assert np.isnan(robot.theta_prior[6:]).all() and robot.theta_prior[4] == 1.0
    assert len(robot.param_names) == 14 and robot.param_names[10] == "Fs1"


def test_kernel_small_solve_against_lapack():
    """The kernels' 4 x 4 solve (LU with partial pivoting, compiled) against numpy's LAPACK solve,
    on random matrices and on one that needs a row exchange at every step (zero leading pivots);
    a singular matrix raises LinAlgError, as numpy's solve does."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        A, b = rng.normal(size=(4, 4)), rng.normal(size=4)
        np.testing.assert_allclose(kern._solve(A, b), np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
    A = np.array([[0.0, 2, 1, 0], [1, 0, 0, 3], [0, 0, 0, 1], [0, 0, 5, 0]])
    b = np.arange(1.0, 5.0)
    np.testing.assert_allclose(kern._solve(A, b), np.linalg.solve(A, b), rtol=1e-14)
    with pytest.raises(np.linalg.LinAlgError, match="singular"):   # as numpy's solve raises
        kern._solve(np.diag([1.0, 2.0, 0.0, 3.0]), b)
