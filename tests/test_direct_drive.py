"""The direct-drive arm and the pendulum toy against the RobotModel contract.

References: the matrices M, C, g, f written out again here from docs/models.md (independent
of the model code), finite differences in time along smooth analytic trajectories, and the
physical-parameter formulas of the paper (section 5).
"""

import numpy as np
import pytest

from boundid.errors import InputError
from boundid.models import DirectDriveArm, LinearToy

RNG = np.random.default_rng(20240501)


def dd_matrices(q, qd, th):
    """M, C, g, f of docs/models.md for one state (written independently of the model)."""
    c2, s2 = np.cos(q[1]), np.sin(q[1])
    M = np.array([[th[0] + 2 * th[1] * c2, th[2] + th[1] * c2], [th[2] + th[1] * c2, th[2]]])
    C = th[1] * s2 * np.array([[-qd[1], -(qd[0] + qd[1])], [qd[0], 0.0]])
    g = np.array([th[3] * np.sin(q[0]) + th[4] * np.sin(q[0] + q[1]), th[4] * np.sin(q[0] + q[1])])
    f = np.array([th[5] * qd[0] + th[7] * np.sign(qd[0]), th[6] * qd[1] + th[8] * np.sign(qd[1])])
    return M, C, g, f


def dd_energy(q, qd, th):
    K = 0.5 * th[0] * qd[0] ** 2 + th[1] * np.cos(q[1]) * (qd[0] ** 2 + qd[0] * qd[1]) \
        + th[2] * (qd[0] * qd[1] + 0.5 * qd[1] ** 2)
    U = th[3] * (1 - np.cos(q[0])) + th[4] * (1 - np.cos(q[0] + q[1]))
    return K + U


def random_states(n, N=50):
    return RNG.uniform(-np.pi, np.pi, (N, n)), RNG.normal(0, 3, (N, n)), RNG.normal(0, 20, (N, n))


def test_theta_from_physical_values():
    """theta_true against the rounded values of docs/models.md and the paper's formulas by hand."""
    m = DirectDriveArm()
    np.testing.assert_allclose(m.theta_true[:5], [2.3516, 0.0838, 0.1019, 38.466, 1.827], rtol=5e-4)
    np.testing.assert_array_equal(m.theta_true[5:], [2.288, 0.175, 7.17, 1.734])
    heavier = DirectDriveArm(m2=5.0)
    assert heavier.theta_true[1] == pytest.approx(0.45 * 5.0 * 0.048)
    assert m.param_names == ("th1", "th2", "th3", "th4", "th5", "b1", "b2", "fc1", "fc2")
    assert len(m.param_units) == 9 and np.array_equal(m.theta_prior, m.theta_true)


def test_regressor_equals_independent_dynamics():
    """Y theta = M qdd + C qd + g + f (matrices of docs/models.md), random states and thetas, 1e-10."""
    m = DirectDriveArm()
    q, qd, qdd = random_states(2)
    for th in (m.theta_true, RNG.uniform(0.1, 5, 9)):
        tau = m.regressor(q, qd, qdd) @ th
        Mb = m.mass_matrix(q, th)
        bias = m.bias_torque(q, qd, th)
        for k in range(len(q)):
            M, C, g, f = dd_matrices(q[k], qd[k], th)
            ref = M @ qdd[k] + C @ qd[k] + g + f
            np.testing.assert_allclose(tau[k], ref, rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(Mb[k], M, rtol=1e-12)
            np.testing.assert_allclose(bias[k], C @ qd[k] + g + f, rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(m.momentum_regressor(q[k], qd[k]) @ th, M @ qd[k], rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(m.energy_regressor(q[k], qd[k]) @ th, dd_energy(q[k], qd[k], th),
                                       rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(m.friction_power_regressor(qd[k]) @ th, qd[k] @ f, rtol=1e-10)


def test_mass_matrix_positive_definite_and_dynamics_round_trip():
    """M(q) is SPD at random poses; forward then inverse dynamics returns the torque (exact sign Coulomb)."""
    m = DirectDriveArm()
    q, qd, _ = random_states(2)
    assert np.all(np.linalg.eigvalsh(m.mass_matrix(q)) > 0)
    tau = RNG.normal(0, 30, q.shape)
    qdd = m.forward_dynamics(q, qd, tau)
    np.testing.assert_allclose(m.inverse_dynamics(q, qd, qdd), tau, rtol=1e-10, atol=1e-9)


def analytic_path(n, t):
    """q = sum of sines (n joints), with exact qd and qdd; velocities never vanish on the t window used."""
    a = np.array([0.7, -0.5, 0.3])[:n]
    w = np.array([1.3, 2.1, 0.9])[:n]
    c = np.array([0.4, -0.3, 0.2])[:n]
    v = np.array([0.8, 0.6, -0.5])[:n]
    q = a * np.sin(w * t[:, None]) + c + v * t[:, None]
    qd = a * w * np.cos(w * t[:, None]) + v
    qdd = -a * w ** 2 * np.sin(w * t[:, None])
    return q, qd, qdd


@pytest.mark.parametrize("model", [DirectDriveArm(), LinearToy()], ids=lambda m: m.name)
def test_momentum_and_energy_forms_by_finite_differences(model):
    """Along an analytic path: d/dt(Ya theta) + Yb theta = Y theta and dH/dt = qd^T (tau - f).

    Time derivatives by the fourth-order central difference (step 1e-3 s, error ~1e-10 here).
    """
    th = model.theta_true
    n, dt = model.n_joints, 1e-3
    t = np.linspace(0.05, 0.35, 7)
    offsets = np.array([-2, -1, 1, 2]) * dt
    weights = np.array([1, -8, 8, -1]) / (12 * dt)

    def ddt(fun):
        vals = [fun(*analytic_path(n, t + o)[:2]) for o in offsets]
        return sum(wk * v for wk, v in zip(weights, vals, strict=True))

    q, qd, qdd = analytic_path(n, t)
    assert np.all(np.abs(qd) > 0.05)
    tau = model.regressor(q, qd, qdd) @ th
    dmom = ddt(lambda q_, qd_: model.momentum_regressor(q_, qd_) @ th)
    np.testing.assert_allclose(dmom + model.remainder_regressor(q, qd) @ th, tau, rtol=1e-8, atol=1e-8)
    dH = ddt(lambda q_, qd_: model.energy_regressor(q_, qd_) @ th)
    power_in = np.sum(qd * tau, axis=1) - model.friction_power_regressor(qd) @ th
    np.testing.assert_allclose(dH, power_in, rtol=1e-8, atol=1e-8)


def test_toy_against_pendulum_equation():
    """LinearToy: Y theta = J qdd + mgl sin q + b qd, H = J qd^2/2 + mgl (1 - cos q), written by hand."""
    toy = LinearToy(m=2.0, l=0.3, I_c=0.02, b=0.4)
    J, mgl, b = 2.0 * 0.09 + 0.02, 2.0 * 9.81 * 0.3, 0.4
    np.testing.assert_allclose(toy.theta_true, [J, mgl, b])
    q, qd, qdd = random_states(1)
    np.testing.assert_allclose(toy.inverse_dynamics(q, qd, qdd), J * qdd + mgl * np.sin(q) + b * qd, rtol=1e-12)
    np.testing.assert_allclose(toy.energy(q, qd), (0.5 * J * qd ** 2 + mgl * (1 - np.cos(q)))[:, 0], rtol=1e-12)
    np.testing.assert_allclose(toy.forward_dynamics(q, qd, np.zeros_like(q)), -(mgl * np.sin(q) + b * qd) / J,
                               rtol=1e-12, atol=1e-12)


def test_bad_input():
    """Wrong shapes, NaN, unknown or negative physical values raise InputError with a message."""
    m = DirectDriveArm()
    with pytest.raises(InputError, match="shape"):
        m.regressor(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(InputError, match="NaN"):
        m.energy_regressor([np.nan, 0.0], [0.0, 0.0])
    with pytest.raises(InputError, match="unknown"):
        DirectDriveArm(mass=3.0)
    with pytest.raises(InputError, match=">= 0"):
        DirectDriveArm(m1=-1.0)
    with pytest.raises(InputError):
        LinearToy(l=np.inf)
    with pytest.raises(InputError, match="theta"):
        m.mass_matrix([0.0, 0.0], theta=np.ones(3))
