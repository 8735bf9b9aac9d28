"""Physical consistency: each model's constraints, the physically consistent feasible set, and
physically consistent estimates.

Independent references: the constraints against their derivations (random rigid bodies built
from point masses, whose pseudo-inertia is the sum of m [r; 1][r; 1]^T; random physical arms
through DirectDriveArm's own definitions; the arm's mass matrix on a grid of q); the bounds, gamma*,
the constrained least squares and the ellipsoid intersections against one cvxpy problem per
optimum written here with every strip at once, no constraint generation and no scaling (Clarabel
on small cases); Chebyshev balls by sampling their surface.
"""

import cvxpy as cp
import numpy as np
import pandas as pd
import pinocchio as pin
import pytest

from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.estimators import OBE, ols
from boundid.estimators.physical import physical_intersection, physical_least_squares
from boundid.models import BaseParameterModel, DirectDriveArm, H4Robot, H4Truth, UrdfRobot
from boundid.models.direct_drive import PHYSICAL, planar_arm_urdf
from boundid.sets import Box, physical
from boundid.sets.constraints import pseudo_inertia
from boundid.sets.physical import PRIMAL_TOL, ConstrainedEllipsoid, PhysicalSet, physical_margin

# ---------------------------------------------------------------------- data


def arm_data(N=200, e=3.0, seed=0, theta=None):
    """Random states of the direct-drive arm, y = W theta + uniform noise in [-e, e]."""
    arm = DirectDriveArm()
    theta = arm.theta_true if theta is None else np.asarray(theta, float)
    rng = np.random.default_rng(seed)
    q, qd, qdd = rng.uniform(-2, 2, (N, 2)), rng.normal(0, 2, (N, 2)), rng.normal(0, 10, (N, 2))
    W = arm.regressor(q, qd, qdd).reshape(-1, 9)
    return arm, W, W @ theta + rng.uniform(-e, e, W.shape[0]), theta


def h4_data(N=100, e=2.0, seed=0):
    robot = H4Robot()
    rng = np.random.default_rng(seed)
    g = robot.geometry
    q = robot.inverse_kinematics(rng.uniform(g.workspace_low, g.workspace_high, (N, 4)))
    W = robot.regressor(q, rng.normal(0, 1, (N, 4)), rng.normal(0, 5, (N, 4))).reshape(-1, 14)
    return robot, W, W @ robot.theta_true + rng.uniform(-e, e, W.shape[0])


@pytest.fixture
def planar(tmp_path):
    return BaseParameterModel(UrdfRobot(planar_arm_urdf(tmp_path), gravity=[0.0, 0.0, -PHYSICAL["g"]]))


def urdf_data(view, N=80, e=0.5, seed=1):
    """Noise-free states within the limits, plus uniform noise in [-e, e] (no simulation needed: the
    regression of an exact experiment is y = Y(q, qd, qdd) beta + noise)."""
    rng = np.random.default_rng(seed)
    lim = view.robot.limits
    q = lim.sample_positions(rng, N)
    qd = rng.uniform(-1, 1, (N, view.n_joints)) * np.minimum(lim.velocity, 3.0)
    qdd = rng.uniform(-1, 1, (N, view.n_joints)) * np.minimum(lim.acceleration, 10.0)
    W = view.regressor(q, qd, qdd).reshape(-1, view.p)
    return W, W @ view.theta_true + rng.uniform(-e, e, W.shape[0])


# ---------------------------------------------------------------------- independent references


def cvxpy_parts(cons, theta_dim):
    """(x, theta, constraints) of the physical set written directly in cvxpy (no scaling)."""
    x = cp.Variable(cons.dim)
    theta = x if not cons.is_lifted else cons.lift @ x
    parts = []
    if cons.linear.m:
        parts.append(cons.linear.A @ x <= cons.linear.b)
    for c in cons.cones:
        parts.append(cp.SOC(c.f @ x + c.d, c.G @ x + c.g))
    for L in cons.lmis:
        M = L.F0 + sum(x[i] * L.F[i] for i in range(cons.dim) if np.any(L.F[i]))
        parts.append(0.5 * (M + M.T) >> 0)
    return x, theta, parts


def cvxpy_bounds(W, y, e, cons, box=None):
    """min and max of each theta_j over every strip, the box and the constraints: 2p cvxpy problems."""
    p = W.shape[1]
    _, theta, parts = cvxpy_parts(cons, p)
    parts.append(cp.abs(y - W @ theta) <= e)
    if box is not None:
        parts += [theta >= box[0], theta <= box[1]]
    lo, hi = np.empty(p), np.empty(p)
    for j in range(p):
        lo[j] = cp.Problem(cp.Minimize(theta[j]), parts).solve(solver=cp.CLARABEL)
        hi[j] = cp.Problem(cp.Maximize(theta[j]), parts).solve(solver=cp.CLARABEL)
    return lo, hi


def cvxpy_gamma(W, y, e, cons, box=None):
    _, theta, parts = cvxpy_parts(cons, W.shape[1])
    t = cp.Variable()
    parts.append(cp.abs(y - W @ theta) <= e * t)
    if box is not None:
        parts += [theta >= box[0], theta <= box[1]]
    return cp.Problem(cp.Minimize(t), parts).solve(solver=cp.CLARABEL)


def assert_bounds_match(b, lo, hi, rel=1e-6):
    w = hi - lo
    np.testing.assert_allclose(b.lo, lo, atol=rel * w.max() + 1e-9 * np.abs(lo).max())
    np.testing.assert_allclose(b.hi, hi, atol=rel * w.max() + 1e-9 * np.abs(hi).max())


# ---------------------------------------------------------------------- the constraints


def test_pseudo_inertia_is_the_second_moment_of_the_mass():
    """Random bodies of 6 point masses: J(theta) = sum m [r; 1][r; 1]^T with theta from pinocchio's own
    Inertia (its parameter order), and check() passes; a body whose principal moments about the centre
    of mass break the triangle inequality (1, 1, 2.5) fails on the LMI."""
    rng = np.random.default_rng(0)
    lmi = pseudo_inertia(10, 0, "J1 >= 0", "")
    for _ in range(20):
        m, r = rng.uniform(0.1, 2.0, 6), rng.normal(0, 0.3, (6, 3))
        body = pin.Inertia.Zero()
        for mk, rk in zip(m, r, strict=True):
            body += pin.Inertia(mk, rk, np.zeros((3, 3)))
        theta = body.toDynamicParameters()
        J = sum(mk * np.outer(np.append(rk, 1), np.append(rk, 1)) for mk, rk in zip(m, r, strict=True))
        np.testing.assert_allclose(lmi.matrix(theta), J, atol=1e-12)
        assert lmi.value(theta[None])[0] <= 1e-12
    bad = pin.Inertia(1.0, np.array([0.1, 0.0, 0.2]), np.diag([1.0, 1.0, 2.5])).toDynamicParameters()
    from boundid.sets.constraints import constraints
    chk = constraints([f"t{i}" for i in range(10)], lmis=[lmi]).check(bad)
    assert not chk.ok and chk.which == "J1 >= 0" and chk.worst > 0


def test_arm_constraints_hold_for_sampled_physical_arms():
    """Masses, lengths (lc in [0, l]), inertias and friction sampled at random: theta (the arm's own
    definitions) satisfies every constraint, and M(q) is positive definite on a grid of q."""
    rng = np.random.default_rng(1)
    q = np.stack(np.meshgrid(np.linspace(-np.pi, np.pi, 9), np.linspace(-np.pi, np.pi, 25)), -1).reshape(-1, 2)
    for _ in range(50):
        l1, l2 = rng.uniform(0.1, 1.0, 2)
        arm = DirectDriveArm(m1=rng.uniform(0.1, 30), m2=rng.uniform(0.1, 10), l1=l1, l2=l2,
                             lc1=rng.uniform(0, l1), lc2=rng.uniform(0, l2), I1=rng.uniform(0, 2),
                             I2=rng.uniform(0, 0.5), b1=rng.uniform(0, 3), b2=rng.uniform(0, 1),
                             fc1=rng.uniform(0, 8), fc2=rng.uniform(0, 2))
        chk = arm.physical_constraints().check(arm.theta_true)
        assert chk.ok, (chk.which, chk.worst)
        assert np.linalg.eigvalsh(arm.mass_matrix(q)).min() > 0


def test_arm_cone_is_mass_matrix_definiteness():
    """th3 (th1 - th3) >= th2^2 (with th3 > 0) holds exactly when M(q) >= 0 at every q: random (th1, th2, th3)
    inside have min eig M >= 0 on a grid of q2; outside, M(q2 = 0) or M(q2 = pi) is indefinite."""
    arm = DirectDriveArm()
    cone = arm.physical_constraints().cones[0]
    rng = np.random.default_rng(2)
    q = np.column_stack([np.zeros(181), np.linspace(-np.pi, np.pi, 181)])
    seen = {True: 0, False: 0}
    for _ in range(400):
        th = arm.theta_true.copy()
        th[:3] = [rng.uniform(0.5, 3), rng.uniform(-1.5, 1.5), rng.uniform(0.05, 0.5)]
        th[0] = th[2] + rng.uniform(0.01, 2.5)
        inside = cone.value(th[None])[0] <= 0
        seen[inside] += 1
        lam = np.linalg.eigvalsh(arm.mass_matrix(q, th)).min(axis=1)
        if inside:
            assert lam.min() >= -1e-12
        else:
            ends = np.linalg.eigvalsh(arm.mass_matrix(np.array([[0, 0], [0, np.pi]]), th)).min()
            assert ends < 0
    assert min(seen.values()) > 50


def test_arm_cone_is_tight_for_the_inertia_triple():
    """Any (th1, th2, th3) in the cone with th2 > 0 comes from a physical arm with the true l1: lc2 in
    [th2 l1 / (th1 - th3), th3 l1 / th2], m2 = th2 / (l1 lc2), I2 = th3 - m2 lc2^2, and I1 (lc1 = 0)
    = th1 - th3 - m2 l1^2, all >= 0; DirectDriveArm gives back the triple."""
    rng = np.random.default_rng(3)
    l1 = PHYSICAL["l1"]
    for _ in range(50):
        th3, d = rng.uniform(0.05, 1), rng.uniform(0.05, 2)
        th2 = rng.uniform(0.01, 1) * np.sqrt(th3 * d)              # th2^2 <= th3 (th1 - th3), th1 = th3 + d
        lc2 = rng.uniform(th2 * l1 / d, th3 * l1 / th2)
        m2 = th2 / (l1 * lc2)
        I2, I1 = th3 - m2 * lc2 ** 2, d - m2 * l1 ** 2
        assert I1 >= -1e-12 and I2 >= -1e-12
        arm = DirectDriveArm(m2=m2, lc2=lc2, lc1=0.0, I1=max(I1, 0.0), I2=max(I2, 0.0))
        np.testing.assert_allclose(arm.theta_true[:3], [th3 + d, th2, th3], atol=1e-12)


def test_h4_constraints():
    """Every H4 parameter is >= 0; the simulated truth (with its arms and rods) satisfies them, each
    label names its parameter, and a negative motor inertia is caught and named."""
    robot = H4Truth(structural=1.0)
    cons = robot.physical_constraints()
    assert cons.is_linear and len(cons) == 14
    assert cons.check(robot.theta_true).ok and np.all(robot.body_parameters() >= 0)
    assert "Imot1 >= 0" in cons.describe() and "dissipates" in cons.describe()
    bad = robot.theta_true.copy()
    bad[0] = -0.006
    chk = cons.check(bad)
    assert not chk.ok and chk.which == "Imot1 >= 0" and chk.worst == pytest.approx(0.006)


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_urdf_constraints_and_their_lift(name):
    """The URDF truth satisfies every pseudo-inertia LMI (and the optional rows); lifted to the base
    parameters, the base truth has a physical preimage (margin >= 0) and a base vector with a negative
    viscous friction has none."""
    robot = UrdfRobot(name, viscous=0.4, coulomb=1.2)
    cons = robot.physical_constraints(triangle=True, cad=0.1)
    assert len(cons.lmis) == robot.n_joints and cons.check(robot.theta_true, tol=1e-12).ok
    view = BaseParameterModel(robot)
    lifted = view.physical_constraints()
    assert lifted.is_lifted and lifted.n_params == view.p and lifted.dim == robot.p
    margin, x = physical_margin(lifted, view.theta_true)
    assert margin >= 0 and np.allclose(view.base.K @ x, view.theta_true, atol=1e-8)
    bad = view.theta_true.copy()
    bad[view.param_names.index("fv1")] = -0.1
    assert physical_margin(lifted, bad)[0] < 0


# ---------------------------------------------------------------------- the set, against cvxpy


def test_lp_case_matches_cvxpy():
    """H4 (linear constraints: the LP path, HiGHS): bounds and gamma* equal the all-strips cvxpy problems;
    the plain bounds go below zero, the physical ones do not."""
    robot, W, y = h4_data(N=60, e=6.0)
    cons = robot.physical_constraints()
    box = (robot.theta_true - 2.0, robot.theta_true + 2.0)
    S = PhysicalSet(W, y, 6.0, cons, box=box)
    b = S.bounds()
    assert b.method == "LP (simplex)"
    assert_bounds_match(b, *cvxpy_bounds(W, y, 6.0, cons, box))
    assert S.consistency().gamma == pytest.approx(cvxpy_gamma(W, y, 6.0, cons, box), rel=1e-6)
    assert np.any(S.plain.bounds().lo < 0) and np.all(b.lo >= 0)
    # membership: the attained minimisers are in P_phys; a point of P with a negative parameter is not
    assert all(S.contains(x) for x in b.argmin)
    below = S.plain.bounds().argmin[int(np.argmin(S.plain.bounds().lo))]
    assert S.plain.contains(below) and not S.contains(below)


def test_soc_case_matches_cvxpy():
    """Direct-drive arm (a cone: the conic path, constraint generation, box frame, dual certificate):
    bounds and gamma* equal the all-strips cvxpy problems; the proven bounds sit within 1e-6 of the
    attained ones."""
    arm, W, y, _ = arm_data(N=40, e=8.0)
    cons = arm.physical_constraints()
    box = (np.full(9, -100.0), np.full(9, 100.0))
    S = PhysicalSet(W, y, 8.0, cons, box=box)
    b = S.bounds()
    assert b.certificate == "dual bound" and b.info["dual_gap"] < 1e-6
    assert_bounds_match(b, *cvxpy_bounds(W, y, 8.0, cons, box))
    assert np.all(b.lo <= b.lo_attained + 1e-9) and np.all(b.hi >= b.hi_attained - 1e-9)
    assert S.consistency().gamma == pytest.approx(cvxpy_gamma(W, y, 8.0, cons, box), rel=1e-6)


def test_lmi_case_matches_cvxpy(planar):
    """2-link URDF in base parameters (pseudo-inertia LMIs on the lifted standard parameters): bounds
    equal the all-strips cvxpy problems over (x, beta = K x); every LMI holds at every optimum's
    standard parameters."""
    W, y = urdf_data(planar, N=40, e=15.0)
    cons = planar.physical_constraints()
    S = PhysicalSet(W, y, 15.0, cons)
    b = S.bounds()
    assert b.certificate == "attained"
    assert_bounds_match(b, *cvxpy_bounds(W, y, 15.0, cons), rel=1e-5)
    for X, Theta in ((b.standard_argmin, b.argmin), (b.standard_argmax, b.argmax)):
        assert np.all(cons.violations(X) <= 1e-6)
        np.testing.assert_allclose(X @ cons.lift.T, Theta, atol=1e-8)


def test_a_solve_that_stops_on_numerical_errors_gets_every_attempt(planar, monkeypatch):
    """Clarabel made to stop on NumericalError unless its static regularisation is at least 1e-6 (as on
    the Panda arms benchmark's 1,673-strip program): the bounds still come, from the last of ATTEMPTS,
    equal to the cvxpy problems over every strip; with one attempt fewer they raise SolverError."""
    import clarabel

    from boundid.sets import conic

    real = clarabel.DefaultSolver

    class Fussy:
        def __init__(self, P, q, A, b, cones, settings):
            self.inner, self.ok = real(P, q, A, b, cones, settings), settings.static_regularization_constant >= 1e-6

        def update(self, **kw):
            self.inner.update(**kw)

        def solve(self):
            sol = self.inner.solve()
            return sol if self.ok else type("Stopped", (), {"status": "NumericalError", "x": sol.x, "z": sol.z})()

    W, y = urdf_data(planar, N=40, e=15.0)
    cons = planar.physical_constraints()
    reference = cvxpy_bounds(W, y, 15.0, cons)
    monkeypatch.setattr(clarabel, "DefaultSolver", Fussy)
    b = PhysicalSet(W, y, 15.0, cons).bounds()
    assert_bounds_match(b, *reference, rel=1e-5)
    monkeypatch.setattr(physical, "ATTEMPTS", conic.ATTEMPTS[:2])
    with pytest.raises(SolverError, match="NumericalError"):
        PhysicalSet(W, y, 15.0, cons).bounds()


# ---------------------------------------------------------------------- the physical bounds


def test_h4_and_arm_bounds_are_physical():
    """Bounds with no negative inertia, mass or friction, inside the plain ones, holding the truth; with
    noise large enough that the plain bounds of some of them go negative."""
    robot, W, y = h4_data(N=80, e=4.0, seed=5)
    box = (robot.theta_true - 2.0, robot.theta_true + 2.0)
    S = PhysicalSet(W, y, 4.0, robot.physical_constraints(), box=box)
    b, pb = S.bounds(), S.plain.bounds()
    tol = 1e-9 * (pb.hi - pb.lo)
    assert np.sum(pb.lo < 0) >= 4 and np.all(b.lo >= 0)
    assert np.all(b.lo >= pb.lo - tol) and np.all(b.hi <= pb.hi + tol)
    assert np.all((b.lo <= robot.theta_true) & (robot.theta_true <= b.hi))
    arm, W, y, _ = arm_data(N=60, e=10.0, seed=6)
    S = PhysicalSet(W, y, 10.0, arm.physical_constraints(), box=(np.full(9, -100.0), np.full(9, 100.0)))
    b, pb = S.bounds(), S.plain.bounds()
    nonneg = [1, 2, 3, 4, 5, 6, 7, 8]                    # th2..th5, b1, b2, fc1, fc2
    assert np.any(pb.lo[nonneg] < 0) and np.all(b.lo[nonneg] >= 0)
    assert np.all(b.lo >= pb.lo) and np.all(b.hi <= pb.hi)
    assert np.all((b.lo <= arm.theta_true) & (arm.theta_true <= b.hi))


def test_urdf_lmi_bounds_contain_the_base_truth(planar):
    """The 2-link URDF's LMI-constrained bounds on a noise-free + bounded-noise experiment hold the base
    truth, sit inside the plain bounds and tighten some of them."""
    W, y = urdf_data(planar, N=100, e=20.0, seed=3)
    S = PhysicalSet(W, y, 20.0, planar.physical_constraints())
    b, pb = S.bounds(), S.plain.bounds()
    truth = planar.theta_true
    assert np.all((b.lo <= truth + 1e-9) & (truth <= b.hi + 1e-9))
    assert np.all(b.lo >= pb.lo - 1e-9) and np.all(b.hi <= pb.hi + 1e-9)
    assert np.any(b.hi - b.lo < 0.9 * (pb.hi - pb.lo))


@pytest.mark.slow  # ~25 s: 96 SDPs with 6 LMIs on 72 standard parameters, and the plain LP bounds
def test_ur5_lmi_bounds_contain_the_base_truth():
    """UR5 in base parameters (48), 300 states within the limits, noise in +-2 N m: the LMI-constrained
    bounds hold the base truth and tighten the plain ones."""
    view = BaseParameterModel(UrdfRobot("ur5", viscous=0.4, coulomb=1.2))
    W, y = urdf_data(view, N=300, e=2.0)
    S = PhysicalSet(W, y, 2.0, view.physical_constraints())
    b, pb = S.bounds(), S.plain.bounds()
    assert np.all((b.lo <= view.theta_true + 1e-9) & (view.theta_true <= b.hi + 1e-9))
    assert np.mean((b.hi - b.lo) / (pb.hi - pb.lo)) < 0.99


def test_data_contradicting_physics_are_reported():
    """Data from an arm with negative viscous friction (b2 = -1, not physical) and small noise: the
    strips alone are consistent, the physical set is empty; the error says so with both gamma*, and
    gamma*_phys matches the independent cvxpy value."""
    theta = DirectDriveArm().theta_true.copy()
    theta[6] = -1.0
    arm, W, y, _ = arm_data(N=60, e=0.5, seed=7, theta=theta)
    cons = arm.physical_constraints()
    S = PhysicalSet(W, y, 0.5, cons)
    c = S.consistency()
    assert c.gamma_plain <= 1 and c.empty and c.physics_matters
    assert c.gamma == pytest.approx(cvxpy_gamma(W, y, 0.5, cons), rel=1e-5)
    with pytest.raises(InfeasibleDataError, match="contradict physics"):
        S.bounds()


def test_chebyshev_ball_is_inside():
    """The arm's physically consistent Chebyshev ball: 2000 points on its sphere satisfy every strip and
    every constraint."""
    arm, W, y, _ = arm_data(N=60, e=10.0, seed=6)
    cons = arm.physical_constraints()
    S = PhysicalSet(W, y, 10.0, cons, box=(np.full(9, -100.0), np.full(9, 100.0)))
    c, r = S.chebyshev_center()
    assert r > 0
    u = np.random.default_rng(0).normal(size=(2000, 9))
    pts = c + r * u / np.linalg.norm(u, axis=1, keepdims=True)
    assert np.all(S.plain.residual_ratio(pts) <= 1 + 1e-9)
    assert np.all(cons.violations(pts) <= 1e-9)


# ---------------------------------------------------------------------- the estimates


def test_physical_least_squares_side_by_side():
    """Arm with zero true viscous friction on joint 2 (b2 = 0): OLS puts it below zero, the constrained
    fit at 0 (the constraint is active) and equals the independent cvxpy constrained least squares; its
    intervals are the raw ones cut at b2 >= 0, and its set (the OLS 95 % ellipsoid ∩ physics) holds the
    constrained centre within the ellipsoid's own bounds."""
    theta = DirectDriveArm().theta_true.copy()
    theta[6] = 0.0
    arm, W, y, _ = arm_data(N=150, e=6.0, seed=2, theta=theta)
    cons = arm.physical_constraints()
    raw = ols(W, y, names=arm.param_names)
    est = physical_least_squares(W, y, cons, names=arm.param_names)
    table = pd.DataFrame({"truth": theta, "OLS": raw.center, "OLS physical": est.center, "raw lo": raw.intervals[0],
                          "lo": est.intervals[0], "raw hi": raw.intervals[1], "hi": est.intervals[1],
                          "set lo": est.info["set_intervals"][0], "set hi": est.info["set_intervals"][1]},
                         index=arm.param_names)
    print(table.to_string(float_format=lambda v: f"{v: .4g}"))
    assert raw.center[6] < 0 and est.center[6] == pytest.approx(0.0, abs=1e-7)
    assert "b2 >= 0" in est.info["active_constraints"] and not est.info["unconstrained_consistent"]
    assert np.all(np.isnan(est.statistics.std_err))
    x, theta_v, parts = cvxpy_parts(cons, 9)
    cp.Problem(cp.Minimize(cp.sum_squares(y - W @ theta_v)), parts).solve(solver=cp.CLARABEL)
    np.testing.assert_allclose(est.center, x.value, atol=1e-6 * np.abs(x.value).max())
    lo, hi = est.intervals
    assert np.all(lo >= raw.intervals[0]) and np.all(hi <= raw.intervals[1]) and lo[6] == 0
    slo, shi = est.info["set_intervals"]
    elo, ehi = raw.set.intervals()
    assert np.all((slo <= est.center + 1e-9) & (est.center <= shi + 1e-9)) and slo[6] >= 0
    assert np.all(slo >= elo - 1e-9) and np.all(shi <= ehi + 1e-9)
    wls_est = physical_least_squares(W, y, cons, groups=np.tile([0, 1], 150), names=arm.param_names)
    assert wls_est.method == "WLS (physical)" and wls_est.center[6] >= -1e-9 and "sigma_groups" in wls_est.info


def test_obe_intersected_with_physics():
    """The OBE ellipsoid of noisy arm data ∩ physics: intervals inside the raw ones, no negative lower bound
    on a nonnegative parameter, the truth kept (still guaranteed), each bound equal to the independent
    cvxpy problem (quadratic form <= 1 plus the constraints)."""
    arm, W, y, theta = arm_data(N=100, e=8.0, seed=12)
    cons = arm.physical_constraints()
    obe = OBE(9, prior=Box.from_center(np.zeros(9), np.full(9, 100.0)), names=arm.param_names).fit(W, y, 8.0)
    est = physical_intersection(obe, cons)
    lo, hi = est.intervals
    assert est.kind == obe.kind == "guaranteed" and est.contains(theta)
    assert np.all(lo >= obe.intervals[0] - 1e-12) and np.all(hi <= obe.intervals[1] + 1e-12)
    assert np.any(obe.intervals[0][1:] < 0) and np.all(lo[1:] >= 0)
    E = obe.set
    x, th, parts = cvxpy_parts(cons, 9)
    parts.append(cp.quad_form(th - E.center, E.information) <= 1)
    for j in (0, 4, 6):
        ref_lo = cp.Problem(cp.Minimize(th[j]), parts).solve(solver=cp.CLARABEL)
        ref_hi = cp.Problem(cp.Maximize(th[j]), parts).solve(solver=cp.CLARABEL)
        w = ref_hi - ref_lo
        assert lo[j] == pytest.approx(ref_lo, abs=1e-6 * w) and hi[j] == pytest.approx(ref_hi, abs=1e-6 * w)


def test_constrained_ellipsoid_is_a_convex_set():
    """contains, support, project and boundary agree with each other and with the intervals."""
    arm, W, y, theta = arm_data(N=100, e=8.0, seed=12)
    obe = OBE(9, prior=Box.from_center(np.zeros(9), np.full(9, 100.0))).fit(W, y, 8.0)
    S = ConstrainedEllipsoid(obe.set, arm.physical_constraints())
    lo, hi = S.intervals()
    assert S.contains(theta) and not S.contains(np.where(np.arange(9) == 6, -0.01, theta))
    assert S.support(np.eye(9)[4]) == pytest.approx(hi[4], rel=1e-7)
    D = np.vstack([np.eye(9)[[4, 6]], -np.eye(9)[[4, 6]]])
    # two solves of one value agree to the conic solve's accuracy, PRIMAL_TOL of the half-widths (the contract)
    np.testing.assert_allclose(S.supports(D), [hi[4], hi[6], -lo[4], -lo[6]], rtol=0,
                               atol=PRIMAL_TOL * float(np.max(hi - lo)))
    sh = S.project(4, 6)
    assert sh.dim == 2 and sh.contains(theta[[4, 6]])
    ring = sh.boundary(16)
    assert ring.shape == (17, 2) and np.all(ring[:, 1] >= -1e-8) and np.all(ring[:, 1] <= hi[6] + 1e-8)
    assert np.isnan(S.log_volume())


# ---------------------------------------------------------------------- failures and bad input


def test_solver_failure_raises_solver_error(monkeypatch):
    arm, W, y, _ = arm_data(N=30)
    S = PhysicalSet(W, y, 3.0, arm.physical_constraints())
    S.plain.bounds()

    def fail(self, *a, **k):
        raise cp.error.SolverError("stalled")

    class Failing:  # the bounds' programs call Clarabel directly (boundid.sets.physical._StripProgram)
        def __init__(self, *a, **k):
            raise RuntimeError("stalled")
    monkeypatch.setattr(cp.Problem, "solve", fail)
    monkeypatch.setattr(physical.clarabel, "DefaultSolver", Failing)
    with pytest.raises(SolverError, match="scaled coordinates"):
        S.bounds()


def test_bad_inputs():
    arm, W, y, _ = arm_data(N=30)
    with pytest.raises(InputError, match="PhysicalConstraints"):
        PhysicalSet(W, y, 3.0, None)
    with pytest.raises(InputError, match="8 columns"):
        PhysicalSet(W[:, :8], y, 3.0, arm.physical_constraints())
    with pytest.raises(InputError, match="same variables"):
        _ = arm.physical_constraints() & H4Robot().physical_constraints()
    with pytest.raises(InputError, match="cad"):
        UrdfRobot("ur5").physical_constraints(cad=-1.0)
