"""The robot contract (:class:`boundid.models.RobotModel`), checked on every registered robot
(:data:`boundid.models.registry.ROBOTS`): shapes, the regressor against the model's own inverse
dynamics, the momentum/remainder identity and the energy identity by finite differences, and the
abilities the other layers ask for."""

from __future__ import annotations

import numpy as np
import pytest

from boundid.experiments.closed_loop import JointPID, simulate_closed_loop
from boundid.models.registry import ROBOTS, make_robot

NAMES = list(ROBOTS)


def _states(model, N: int, seed: int = 0):
    """N states near the robot's home (small angles keep the H4 inside its workspace)."""
    rng = np.random.default_rng(seed)
    n = model.n_joints
    q = 0.1 * rng.standard_normal((N, n))
    return q, 0.3 * rng.standard_normal((N, n)), rng.standard_normal((N, n))


@pytest.mark.parametrize("name", NAMES)
def test_single_state_and_batch_shapes(name):
    """Reference: the documented rule of models/base.py: a single state (n,) gives the batch
    result without the sample axis, for every robot."""
    m = make_robot(name)
    n, p = m.n_joints, m.p
    q, qd, qdd = _states(m, 5)
    assert m.regressor(q, qd, qdd).shape == (5, n, p)
    assert m.momentum_regressor(q, qd).shape == (5, n, p)
    assert m.remainder_regressor(q, qd).shape == (5, n, p)
    assert m.energy_regressor(q, qd).shape == (5, p)
    assert m.friction_power_regressor(qd).shape == (5, p)
    assert m.mass_matrix(q).shape == (5, n, n)
    assert m.bias_torque(q, qd).shape == (5, n)
    assert m.forward_dynamics(q, qd, qdd).shape == (5, n)
    one = (q[2], qd[2], qdd[2])
    np.testing.assert_allclose(m.regressor(*one), m.regressor(q, qd, qdd)[2], rtol=1e-12, atol=1e-12)
    assert m.momentum_regressor(q[2], qd[2]).shape == (n, p)
    assert m.energy_regressor(q[2], qd[2]).shape == (p,)
    assert m.friction_power_regressor(qd[2]).shape == (p,)
    assert m.mass_matrix(q[2]).shape == (n, n)
    assert m.bias_torque(q[2], qd[2]).shape == (n,)
    assert m.inverse_dynamics(*one).shape == (n,)
    np.testing.assert_allclose(m.forward_dynamics(q[2], qd[2], qdd[2]), m.forward_dynamics(q, qd, qdd)[2],
                               rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_regressor_times_theta_is_the_inverse_dynamics(name):
    """Reference: the model's own M(q) qdd + bias (Coulomb as sign): Y theta equals it, and the
    forward dynamics invert it."""
    m = make_robot(name)
    q, qd, qdd = _states(m, 6, seed=1)
    tau = np.einsum("nij,nj->ni", m.mass_matrix(q), qdd) + m.bias_torque(q, qd)
    np.testing.assert_allclose(m.regressor(q, qd, qdd) @ m.theta_true, tau, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(m.forward_dynamics(q, qd, tau), qdd, rtol=1e-7, atol=1e-7)
    acc = m.fast_acceleration(q[0].tolist(), qd[0].tolist(), tau[0].tolist(), m.theta_true.tolist(), 0.0)
    np.testing.assert_allclose(acc, qdd[0], rtol=1e-7, atol=1e-7)


def _trajectory(m, h: float, K: int):
    t = np.arange(K) * h
    n = m.n_joints
    w = 1.0 + 0.3 * np.arange(n)
    q = 0.1 * np.sin(np.outer(t, w) + np.arange(n))
    qd = 0.1 * w * np.cos(np.outer(t, w) + np.arange(n))
    qdd = -0.1 * w**2 * np.sin(np.outer(t, w) + np.arange(n))
    return q, qd, qdd


@pytest.mark.parametrize("name", NAMES)
def test_momentum_and_energy_identities(name):
    """Reference: central finite differences (h = 1e-4 s) of the momentum Ya theta and the energy
    H along a smooth trajectory: d/dt(Ya theta) + Yb theta = Y theta, and
    dH/dt = qd^T (tau - f) with the friction power qd^T f = phi_f theta."""
    m = make_robot(name)
    h, th = 1e-4, m.theta_true
    q, qd, qdd = _trajectory(m, h, 7)
    tau = m.regressor(q, qd, qdd) @ th
    momentum = m.momentum_regressor(q, qd) @ th
    dmom = (momentum[2:] - momentum[:-2]) / (2 * h)
    lhs = dmom + (m.remainder_regressor(q, qd) @ th)[1:-1]
    np.testing.assert_allclose(lhs, tau[1:-1], rtol=1e-5, atol=1e-5 * max(1.0, np.abs(tau).max()))
    H = m.energy_regressor(q, qd) @ th
    dH = (H[2:] - H[:-2]) / (2 * h)
    power = np.einsum("ni,ni->n", qd, tau) - m.friction_power_regressor(qd) @ th
    np.testing.assert_allclose(dH, power[1:-1], rtol=1e-5, atol=1e-5 * max(1.0, np.abs(power).max()))


@pytest.mark.parametrize("name", NAMES)
def test_closed_loop_simulation_runs_for_every_robot(name):
    """Reference: the controller's purpose: a PD loop with per-joint gain and torque limit holds
    each robot near a constant reference (error well below the 0.05 rad step), whatever its
    stepper (compiled or the generic RK4 of forward_dynamics)."""
    m = make_robot(name)
    n = m.n_joints
    target = np.full(n, 0.05)

    class Hold:
        def evaluate(self, t):
            z = np.zeros((len(t), n))
            return z + target, z, z

    inertia = np.abs(np.diag(m.mass_matrix(np.zeros(n)))) + 1e-3
    pid = JointPID.from_bandwidth(inertia, 5.0)
    gain, limit = np.linspace(1.0, 2.0, n), np.full(n, 1e4)
    run = simulate_closed_loop(m, Hold(), 0.6, pid, amplifier_gain=gain, torque_limit=limit, q0=np.zeros(n),
                               coulomb_width=0.01)
    assert run.q.shape == (600, n) and np.all(np.isfinite(run.q))
    np.testing.assert_allclose(run.tau, run.v_ref * gain)
    assert np.abs(run.q[-1] - target).max() < 0.02


@pytest.mark.parametrize("name", NAMES)
def test_abilities_have_the_declared_types(name):
    """Reference: the defaults of RobotModel: experiments among the known ones; a workspace
    measure >= 0; the Options dataclass rebuilds the default robot."""
    m = make_robot(name)
    assert set(m.experiments) <= {"open_loop", "closed_loop", "tracking"}
    q = _states(m, 4)[0]
    assert m.workspace_excursion(q) >= 0.0
    assert m.outside_workspace(q) is None
    assert m.rest_position().shape == (m.n_joints,) and m.outside_workspace(m.rest_position()[None]) is None
    assert m.limits is None or m.limits.effort.shape == (m.n_joints,)
    entry = ROBOTS[name]
    np.testing.assert_array_equal(entry.from_options(entry.Options()).theta_true, m.theta_true)
