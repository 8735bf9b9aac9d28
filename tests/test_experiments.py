"""Excitation, simulation, measurement, filters and sample pairing.

References: the paper's torque formulas (31)-(32) typed again here; exact zero-order-hold
discretisation of a linear system by scipy.signal.cont2discrete; conservation of energy; the
paper's closed-form discrete filters; continuous-time frequency responses and step responses;
analytic integrals.
"""

import numpy as np
import pytest
from scipy.integrate import trapezoid
from scipy.signal import cont2discrete

from boundid.errors import InputError
from boundid.experiments.excitation import RampedMultisine
from boundid.experiments.filters import FirstOrderFilters, align, cumulative_integral, paper_pairing, zoh_midpoint
from boundid.experiments.measurement import TorqueNoise
from boundid.experiments.simulation import measure, simulate_open_loop, simulate_sampled
from boundid.models import DirectDriveArm, LinearToy, RobotModel

H = 2.5e-3
LAM = 50.0


def test_paper_torques_match_equations_31_32():
    """tau1, tau2 of the paper, written out here, at a few times; vectorised and scalar calls."""
    exc = RampedMultisine.direct_drive_paper()
    t = np.array([0.0, 0.37, 1.0, 9.99])
    tau1 = (1 - np.exp(-0.8 * t)) * 29.0 + 68 * np.sin(16 * t + 0.1) + 9 * np.sin(20 * t + 0.15)
    tau2 = (1 - np.exp(-1.8 * t)) * 1.2 + 8 * np.sin(26 * t + 0.08) + 2 * np.sin(12 * t + 0.34)
    np.testing.assert_allclose(exc(t), np.column_stack([tau1, tau2]), rtol=1e-14, atol=1e-13)
    np.testing.assert_allclose(exc(0.37), [tau1[1], tau2[1]], rtol=1e-14)
    assert exc.max_frequency == 26.0 and exc.n_joints == 2
    with pytest.raises(InputError, match="per joint"):
        RampedMultisine(offset=(1.0,), rate=(1.0, 2.0), amplitude=((1.0,),), frequency=((1.0,),), phase=((0.0,),))


def test_zero_order_hold_is_exact_on_a_linear_plant():
    """Toy with mgl = 0 is linear (J qdd + b qd = u): the simulation under held torques equals the
    exact ZOH discretisation by scipy.signal.cont2discrete, to 1e-9."""
    toy = LinearToy(m=1.0, l=0.5, I_c=0.01, b=0.8, g=0.0)
    J, b = toy.theta_true[0], toy.theta_true[2]
    rng = np.random.default_rng(3)
    U = rng.normal(0, 2, (201, 1))
    traj = simulate_open_loop(toy, U, 0.5, H, q0=[0.3], qd0=[-1.0])
    A = np.array([[0.0, 1.0], [0.0, -b / J]])
    B = np.array([[0.0], [1.0 / J]])
    Ad, Bd, *_ = cont2discrete((A, B, np.eye(2), np.zeros((2, 1))), H, method="zoh")
    x = np.array([0.3, -1.0])
    ref = [x]
    for k in range(200):
        x = Ad @ x + Bd @ U[k]
        ref.append(x)
    ref = np.array(ref)
    np.testing.assert_allclose(traj.q[:, 0], ref[:, 0], atol=1e-9)
    np.testing.assert_allclose(traj.qd[:, 0], ref[:, 1], atol=1e-9)
    np.testing.assert_allclose(traj.qdd[:, 0], (U[:, 0] - b * ref[:, 1]) / J, atol=1e-8)
    assert traj.t.shape == (201,) and traj.t[-1] == pytest.approx(0.5)


def test_fast_path_matches_the_contract_path():
    """The fast_acceleration hook: same qdd as forward_dynamics at random states, and the same
    simulated trajectory as the generic mass_matrix/bias_torque path (1e-9)."""
    arm = DirectDriveArm()
    rng = np.random.default_rng(4)
    for _ in range(20):
        q, qd, u = rng.normal(0, 2, 2), rng.normal(0, 3, 2), rng.normal(0, 30, 2)
        for w in (0.0, 0.01):
            np.testing.assert_allclose(arm.fast_acceleration(q, qd, u, arm.theta_true, w),
                                       arm.forward_dynamics(q, qd, u, coulomb_width=w), rtol=1e-12, atol=1e-12)

    class PlainArm(DirectDriveArm):
        fast_acceleration = RobotModel.fast_acceleration  # the default: mass_matrix and bias_torque
        compiled_acceleration = None

    exc = RampedMultisine.direct_drive_paper()
    fast = simulate_open_loop(arm, exc, 0.25, H)
    plain = simulate_open_loop(PlainArm(), exc, 0.25, H)
    assert fast.info["fast_path"] and not plain.info["fast_path"]
    np.testing.assert_allclose(fast.q, plain.q, atol=1e-9)
    np.testing.assert_allclose(fast.qd, plain.qd, atol=1e-8)


def test_compiled_hold_integrator_matches_solve_ivp():
    """The compiled DOP853 hold integrator against scipy's solve_ivp (DOP853, first_step = h) on each
    interval, the independent reference: same number of right-hand-side evaluations (same accepted and
    rejected steps) and the same trajectory up to rounding (1e-12), with and without Coulomb smoothing."""

    class ScipyArm(DirectDriveArm):
        compiled_acceleration = None

    exc = RampedMultisine.direct_drive_paper()
    for w, tol in ((0.01, 1e-10), (0.05, 1e-8)):
        comp = simulate_open_loop(DirectDriveArm(), exc, 1.0, H, q0=[0.2, -0.1], coulomb_width=w, rtol=tol, atol=tol)
        ref = simulate_open_loop(ScipyArm(), exc, 1.0, H, q0=[0.2, -0.1], coulomb_width=w, rtol=tol, atol=tol)
        assert comp.info["engine"].startswith("compiled") and ref.info["engine"] == "scipy solve_ivp"
        assert comp.info["nfev"] == ref.info["nfev"]
        np.testing.assert_allclose(comp.q, ref.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(comp.qd, ref.qd, rtol=0, atol=1e-11)
        np.testing.assert_array_equal(comp.tau, ref.tau)


def test_free_arm_conserves_energy():
    """No friction, no torque, released from a displaced, moving state: H constant to 1e-9 J over 1 s."""
    arm = DirectDriveArm()
    theta = arm.theta_true.copy()
    theta[5:] = 0.0
    traj = simulate_sampled(arm, lambda t, q, qd: np.zeros(2), 1.0, H, q0=[1.0, -0.5], qd0=[0.0, 1.0], theta=theta)
    Hs = arm.energy(traj.q, traj.qd, theta)
    assert Hs[0] > 10.0
    assert np.max(np.abs(Hs - Hs[0])) < 1e-9
    assert np.ptp(traj.q[:, 1]) > 0.5           # it really moved


def test_supplied_energy_identity_along_simulation():
    """Work of the held torques sum_k u[k]^T (q[k+1] - q[k]) (exact for a zero-order hold) equals
    H(T) - H(0) (no friction: to 1e-8 J) and H(T) - H(0) + int qd^T f (with the smoothed friction of
    the simulation, trapezoid rule: to 2e-3 relative)."""
    arm = DirectDriveArm()
    exc = RampedMultisine.direct_drive_paper()
    theta = arm.theta_true.copy()
    theta[5:] = 0.0
    free = simulate_open_loop(arm, exc, 0.5, H, theta=theta)
    work = np.sum(free.tau[:-1] * np.diff(free.q, axis=0))
    Hs = arm.energy(free.q, free.qd, theta)
    assert work > 1.0
    assert abs(work - (Hs[-1] - Hs[0])) < 1e-8

    w = 0.01
    traj = simulate_open_loop(arm, exc, 1.0, H, coulomb_width=w)
    th = arm.theta_true
    fpow = np.sum(traj.qd * (th[5:7] * traj.qd + th[7:9] * np.tanh(traj.qd / w)), axis=1)
    work = np.sum(traj.tau[:-1] * np.diff(traj.q, axis=0))
    Hs = arm.energy(traj.q, traj.qd)
    assert work == pytest.approx(Hs[-1] - Hs[0] + trapezoid(fpow, traj.t), rel=2e-3)


def test_measure_quantises_and_adds_noise():
    """16-bit encoder: q on the 2 pi / 2^16 grid within half a step; torque noise of std 2 N m;
    qd the backward difference of the quantised q."""
    arm = DirectDriveArm()
    traj = simulate_open_loop(arm, RampedMultisine.direct_drive_paper(), 0.5, H)
    meas = measure(traj, 2 ** 16, TorqueNoise("gaussian", 2.0), np.random.default_rng(0))
    step = 2 * np.pi / 2 ** 16
    np.testing.assert_allclose(meas.q / step, np.round(meas.q / step), atol=1e-6)
    assert np.max(np.abs(meas.q - traj.q)) <= 0.5 * step + 1e-12
    assert np.std(meas.tau - traj.tau) == pytest.approx(2.0, rel=0.1)
    np.testing.assert_allclose(meas.qd[1:], np.diff(meas.q, axis=0) / H)
    assert meas.qdd is None and meas.info["counts_per_rev"] == 2 ** 16
    with pytest.raises(InputError, match="rng"):
        measure(traj, noise=TorqueNoise("gaussian", 1.0))


def test_simulation_bad_input():
    """t_end not a whole number of periods, wrong torque shape, negative width: InputError."""
    arm = DirectDriveArm()
    with pytest.raises(InputError, match="whole number"):
        simulate_open_loop(arm, RampedMultisine.direct_drive_paper(), 0.0101, H)
    with pytest.raises(InputError, match="shape"):
        simulate_open_loop(arm, np.zeros((5, 3)), 0.01, H)
    with pytest.raises(InputError, match="coulomb_width"):
        simulate_open_loop(arm, np.zeros((5, 2)), 0.01, H, coulomb_width=-1.0)


# -- filters ------------------------------------------------------------------------------------
def test_paper_discretisation_equals_the_papers_closed_forms():
    """control.c2d(zoh) coefficients = (1 - e^{-h lam}) z^-1 / (1 - e^{-h lam} z^-1) and
    (1 - z^-1) lam / (1 - e^{-h lam} z^-1); Tustin = the bilinear closed forms."""
    a = np.exp(-H * LAM)
    paper = FirstOrderFilters(LAM, H, "paper")
    for got, ref in zip(paper.lowpass_coefficients, ([0.0, 1 - a], [1.0, -a]), strict=True):
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15)
    for got, ref in zip(paper.derivative_coefficients, ([LAM, -LAM], [1.0, -a]), strict=True):
        np.testing.assert_allclose(got, ref, rtol=1e-12)
    c = LAM * H / 2
    tus = FirstOrderFilters(LAM, H, "tustin")
    np.testing.assert_allclose(tus.lowpass_coefficients[0], [c / (1 + c), c / (1 + c)], rtol=1e-12)
    np.testing.assert_allclose(tus.lowpass_coefficients[1], [1.0, -(1 - c) / (1 + c)], rtol=1e-12)
    np.testing.assert_allclose(tus.derivative_coefficients[0], [LAM / (1 + c), -LAM / (1 + c)], rtol=1e-12)


def test_paper_lowpass_is_exact_on_held_inputs():
    """A unit step is a held signal: the paper's low-pass gives the continuous response 1 - e^{-lam t_k}
    exactly (delayed by one sample: the step acts from t_0)."""
    y = FirstOrderFilters(LAM, H, "paper").lowpass(np.ones(200))
    t = np.arange(200) * H
    np.testing.assert_allclose(y, 1 - np.exp(-LAM * t), atol=1e-13)


def test_discretisations_on_a_continuous_signal():
    """Sampled sin(16 t), steady state, against the continuous responses G(j w) of lam/(s+lam) and
    lam s/(s+lam): Tustin is within 1e-4 / 2e-4 of the amplitude at t_k; the paper's low-pass
    matches the response h/2 earlier instead, and its derivative filter is ~6 % too large,
    the gain lam h / (1 - e^{-lam h}) = 1.064 (the 6 % inertia bias of docs/models.md)."""
    w, t = 16.0, np.arange(4000) * H
    x = np.sin(w * t)
    G_lp, G_d = LAM / (1j * w + LAM), LAM * 1j * w / (1j * w + LAM)

    def resp(G, shift=0.0):
        return np.abs(G) * np.sin(w * (t - shift) + np.angle(G))

    ss = slice(2000, None)
    tus = FirstOrderFilters(LAM, H, "tustin")
    assert np.max(np.abs(tus.lowpass(x) - resp(G_lp))[ss]) < 1e-4 * np.abs(G_lp)
    assert np.max(np.abs(tus.derivative(x) - resp(G_d))[ss]) < 2e-4 * np.abs(G_d)
    paper = FirstOrderFilters(LAM, H, "paper")
    assert np.max(np.abs(paper.lowpass(x) - resp(G_lp, H / 2))[ss]) < 1e-3 * np.abs(G_lp)
    assert np.max(np.abs(paper.lowpass(x) - resp(G_lp))[ss]) > 1e-2 * np.abs(G_lp)
    # low-frequency gain of the paper's derivative filter (closed form) vs Tustin's (1)
    z = np.exp(1j * 1e-3 * H)
    b, a = paper.derivative_coefficients
    gain = (b[0] + b[1] / z) / (a[0] + a[1] / z) / (1j * 1e-3)
    assert gain.real == pytest.approx(LAM * H / (1 - np.exp(-LAM * H)), rel=1e-5)
    assert gain.real == pytest.approx(1.064, abs=1e-3)
    b, a = tus.derivative_coefficients
    assert ((b[0] + b[1] / z) / (a[0] + a[1] / z) / (1j * 1e-3)).real == pytest.approx(1.0, rel=1e-5)


def test_filters_bad_input():
    with pytest.raises(InputError, match="discretisation"):
        FirstOrderFilters(LAM, H, "bilinear")
    with pytest.raises(InputError, match="lam"):
        FirstOrderFilters(-1.0, H)


def test_cumulative_integral_of_a_sine():
    """Trapezoid running integral of cos against sin, error below h^2/12 max|cos''| t."""
    t = np.arange(0, 2.0 + H / 2, H)
    x = np.column_stack([np.cos(3 * t), np.cos(5 * t)])
    ref = np.column_stack([np.sin(3 * t) / 3, np.sin(5 * t) / 5])
    err = np.abs(cumulative_integral(x, t) - ref)
    assert err[0].max() == 0.0
    assert err.max() < H ** 2 / 12 * 25 * 2.0


# -- sample pairing -----------------------------------------------------------------------------
def test_zoh_midpoint_pairing():
    """Midpoint pairing: tau[k] with (q[k] + q[k+1])/2 and (q[k+1] - q[k])/h at t = (k + 1/2) h, so
    tau^T qd h is the exact work of the interval; the paper's pairing keeps q[k] and the backward
    difference."""
    rng = np.random.default_rng(1)
    q, tau = np.cumsum(rng.normal(0, 0.01, (50, 2)), axis=0), rng.normal(0, 5, (50, 2))
    mid = zoh_midpoint(q, tau, H, t0=1.0)
    assert mid.q.shape == (49, 2) and mid.pairing == "zoh_midpoint"
    np.testing.assert_allclose(mid.t, 1.0 + (np.arange(49) + 0.5) * H)
    np.testing.assert_allclose(mid.q[3], 0.5 * (q[3] + q[4]))
    np.testing.assert_allclose(np.sum(mid.tau * mid.qd, axis=1) * H, np.sum(tau[:-1] * np.diff(q, axis=0), axis=1))
    pap = paper_pairing(q, tau, H)
    assert pap.q.shape == (50, 2)
    np.testing.assert_allclose(pap.qd[5], (q[5] - q[4]) / H)
    np.testing.assert_array_equal(align(q, tau, H, "paper").tau, tau)
    with pytest.raises(InputError, match="pairing"):
        align(q, tau, H, "middle")
    with pytest.raises(InputError, match="same|both"):
        zoh_midpoint(q, tau[:10], H)
