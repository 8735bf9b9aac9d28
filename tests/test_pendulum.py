"""The one-link pendulum, reached through the robot registry only (the extension point: a robot
is its module plus one registry line). The contract itself is tests/test_robot_contract.py."""

from __future__ import annotations

import numpy as np
import pytest

from boundid.errors import InputError
from boundid.models.registry import ROBOTS, make_robot


def test_pendulum_torque_is_the_textbook_equation():
    """Reference: tau = (I_c + m lc^2) qdd + m g lc sin q + b qd + fc sign(qd) written from the
    physical options (parallel-axis theorem), not from the model's parameters."""
    o = dict(m=2.0, lc=0.3, I_c=0.05, b=0.1, fc=0.4, g=9.81)
    m = make_robot("pendulum", o)
    q, qd, qdd = np.array([[0.7], [-1.2]]), np.array([[0.5], [-0.3]]), np.array([[2.0], [1.5]])
    ref = ((o["I_c"] + o["m"] * o["lc"] ** 2) * qdd + o["m"] * o["g"] * o["lc"] * np.sin(q) + o["b"] * qd
           + o["fc"] * np.sign(qd))
    np.testing.assert_allclose(m.inverse_dynamics(q, qd, qdd), ref, rtol=1e-14)
    assert type(m).Options().lc == 0.4 and "pendulum" in ROBOTS


def test_small_oscillation_period():
    """Reference: the small-angle period 2 pi sqrt(J / mgl) of a frictionless pendulum; the
    simulated zero crossings (scipy's DOP853 through the model's forward dynamics) agree to 1e-4."""
    from boundid.experiments.simulation import simulate_sampled

    m = make_robot("pendulum", {"b": 0.0, "fc": 0.0})
    J, mgl = m.theta_true[:2]
    period = 2 * np.pi * np.sqrt(J / mgl)
    run = simulate_sampled(m, lambda t, q, qd: np.zeros(1), round(3 * period, 3), 1e-3, q0=[1e-3], qd0=[0.0])
    up = np.flatnonzero((run.q[:-1, 0] < 0) & (run.q[1:, 0] >= 0))
    t_up = run.t[up] - run.q[up, 0] / (run.q[up + 1, 0] - run.q[up, 0]) * 1e-3
    np.testing.assert_allclose(np.diff(t_up), period, rtol=1e-4)


def test_bad_options_are_refused():
    with pytest.raises(InputError, match="pendulum options must be finite and >= 0"):
        make_robot("pendulum", {"m": -1.0})
