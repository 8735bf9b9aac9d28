"""URDF arms through pinocchio: regressors, base parameters, excitation within limits, export.

References, independent of the code under test: pinocchio's own RNEA, CRBA, energies and Coriolis
matrix on a model the test builds from the file; central finite differences in time (momentum)
and in q (kinetic energy) along analytic trajectories; the closed-form regrouping of the UR5's
parallel joints (a2 = 0.425 m, read from its URDF); numpy's SVD rank; the closed-form
direct-drive arm (DirectDriveArm) against a 2-link URDF written here with its masses and lengths.
"""

import numpy as np
import pandas as pd
import pinocchio as pin
import pytest
import yaml

from boundid.errors import InputError
from boundid.experiments.excitation import RampedMultisine
from boundid.experiments.filters import align
from boundid.experiments.limited_trajectories import (
    fit_to_limits,
    fourier_within_limits,
    limit_usage,
    optimize_within_limits,
)
from boundid.experiments.regression import filtered_dynamic, filtered_power, inverse_dynamic, supplied_energy
from boundid.experiments.simulation import simulate_open_loop, simulate_sampled
from boundid.experiments.trajectories import FourierTrajectory, SegmentedTrajectory
from boundid.models import DirectDriveArm
from boundid.models.base_parameters import BaseParameterModel, base_parameters
from boundid.models.direct_drive import PHYSICAL, planar_arm_urdf
from boundid.models.urdf import EXAMPLE_ROBOTS, UrdfRobot, example_robots_dir
from boundid.models.urdf_export import parameter_table, write_parameters, write_urdf

ARMS = ["ur5", "panda"]


@pytest.fixture(scope="module")
def robots():
    """UR5 and Panda (arm joints) with friction; built once (about 0.1 s each)."""
    return {"ur5": UrdfRobot("ur5", viscous=0.4, coulomb=1.2),
            "panda": UrdfRobot("panda", viscous=[0.3, 0.3, 0.3, 0.3, 0.1, 0.1, 0.1], coulomb=0.8)}


@pytest.fixture(scope="module")
def bases(robots):
    return {k: base_parameters(r) for k, r in robots.items()}


def reference_model(name):
    """pinocchio's model of the arm, built here from the file (Panda: fingers locked at 0)."""
    path = example_robots_dir() / EXAMPLE_ROBOTS[name][0]
    full = pin.buildModelFromUrdf(str(path))
    if name == "panda":
        lock = [full.getJointId(j) for j in ("panda_finger_joint1", "panda_finger_joint2")]
        return pin.buildReducedModel(full, lock, pin.neutral(full))
    return full


def states(robot, N=30, seed=1):
    rng = np.random.default_rng(seed)
    lim = robot.limits
    return (lim.sample_positions(rng, N), rng.uniform(-1, 1, (N, robot.n_joints)) * lim.velocity,
            rng.uniform(-1, 1, (N, robot.n_joints)) * lim.acceleration)


def friction(robot, qd, th=None):
    th = robot.theta_true if th is None else th
    n = robot.n_joints
    fv, fc = th[10 * n:11 * n], th[11 * n:12 * n]
    return fv * qd + fc * np.sign(qd)


def analytic_motion(n, t):
    """Smooth q, qd, qdd (n joints) at time t, at rest (qd = 0) at t = 0, incommensurate frequencies."""
    w = np.linspace(0.7, 1.9, n)
    return 0.3 + 0.6 * (1.0 - np.cos(w * t)), 0.6 * w * np.sin(w * t), 0.6 * w * w * np.cos(w * t)


# -- the model against pinocchio's algorithms ------------------------------------------------
@pytest.mark.parametrize("name", ARMS)
def test_regressor_times_urdf_theta_equals_rnea(robots, name):
    """Y(q, qd, qdd) theta_URDF = pinocchio RNEA + friction over random states within the limits, to 1e-10 N m."""
    robot, model = robots[name], reference_model(name)
    data = model.createData()
    q, qd, qdd = states(robot)
    tau = robot.regressor(q, qd, qdd) @ robot.theta_true
    ref = np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(len(q))]) + friction(robot, qd)
    assert np.abs(tau - ref).max() < 1e-10
    assert robot.regressor(q[0], qd[0], qdd[0]).shape == (robot.n_joints, robot.p)  # one state: no sample axis


@pytest.mark.parametrize("name", ARMS)
def test_energy_regressor_equals_pinocchio_energies(robots, name):
    """phi_H theta = computeKineticEnergy + computePotentialEnergy, to 1e-10 J."""
    robot, model = robots[name], reference_model(name)
    data = model.createData()
    q, qd, _ = states(robot)
    H = robot.energy(q, qd)
    ref = [pin.computeKineticEnergy(model, data, q[k], qd[k]) + pin.computePotentialEnergy(model, data, q[k])
           for k in range(len(q))]
    assert np.abs(H - ref).max() < 1e-10
    np.testing.assert_allclose(robot.friction_power_regressor(qd) @ robot.theta_true,
                               np.sum(qd * friction(robot, qd), axis=1), rtol=1e-12)


@pytest.mark.parametrize("name", ARMS)
def test_momentum_regressor(robots, name):
    """Ya theta = M(q) qd with M from pinocchio's CRBA on the model built here."""
    robot, model = robots[name], reference_model(name)
    data = model.createData()
    q, qd, _ = states(robot, N=10)
    Ya = robot.momentum_regressor(q, qd)
    for k in range(len(q)):
        M = pin.crba(model, data, q[k])
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(Ya[k] @ robot.theta_true, M @ qd[k], atol=1e-12)


@pytest.mark.parametrize("name", ARMS)
def test_remainder_regressor_by_finite_differences(robots, name):
    """d/dt(Ya theta) + Yb theta = Y theta along an analytic motion (central differences, h = 1e-5 s);
    and the kinetic part of Yb is -dK/dq = -C^T qd (pinocchio's Coriolis matrix, and finite differences of K in q)."""
    robot, model = robots[name], reference_model(name)
    data = model.createData()
    n, th, h = robot.n_joints, robot.theta_true, 1e-5
    for t in (0.3, 1.7):
        q, qd, qdd = analytic_motion(n, t)
        dp = (robot.momentum_regressor(*analytic_motion(n, t + h)[:2]) @ th
              - robot.momentum_regressor(*analytic_motion(n, t - h)[:2]) @ th) / (2 * h)
        lhs = dp + robot.remainder_regressor(q, qd) @ th
        np.testing.assert_allclose(lhs, robot.regressor(q, qd, qdd) @ th, atol=1e-6)
        gravity = pin.computeGeneralizedGravity(model, data, q)
        dK_dq = gravity + friction(robot, qd[None])[0] - robot.remainder_regressor(q, qd) @ th
        C = pin.computeCoriolisMatrix(model, data, q, qd)
        np.testing.assert_allclose(dK_dq, C.T @ qd, atol=1e-12)
        e = 1e-6
        K = [[pin.computeKineticEnergy(model, data, q + s * e * u, qd) for s in (1, -1)] for u in np.eye(n)]
        fd = [(kp - km) / (2 * e) for kp, km in K]
        np.testing.assert_allclose(dK_dq, fd, atol=1e-7)


@pytest.mark.parametrize("name", ARMS)
def test_aba_equals_mass_matrix_solve(robots, name):
    """Forward dynamics by ABA = solve(M (CRBA), tau - bias (RNEA + friction)), and inverts the regressor."""
    robot = robots[name]
    q, qd, qdd = states(robot)
    tau = robot.inverse_dynamics(q, qd, qdd)
    acc = robot.forward_dynamics(q, qd, tau)
    ref = np.linalg.solve(robot.mass_matrix(q), (tau - robot.bias_torque(q, qd))[..., None])[..., 0]
    np.testing.assert_allclose(acc, ref, atol=1e-9)
    np.testing.assert_allclose(acc, qdd, atol=1e-9)
    one = robot.fast_acceleration(q[0].tolist(), qd[0].tolist(), tau[0].tolist(), robot.theta_true.tolist(), 0.0)
    np.testing.assert_allclose(one, qdd[0], atol=1e-9)


def test_armature_and_offset_columns():
    """With armature and offsets: Y theta = RNEA with pinocchio's armature + friction + offset; the kinetic energy
    (with Ia qd^2 / 2) equals pinocchio's."""
    ia, off = np.linspace(0.1, 0.6, 6), np.linspace(-1.0, 1.0, 6)
    robot = UrdfRobot("ur5", viscous=0.4, coulomb=1.2, with_armature=True, armature=ia, with_offset=True, offset=off)
    assert robot.p == 84 and robot.param_names[60] == "Ia1" and robot.param_names[-1] == "off6"
    model = reference_model("ur5")
    model.armature = ia
    data = model.createData()
    q, qd, qdd = states(robot, N=10)
    tau = robot.inverse_dynamics(q, qd, qdd)
    ref = np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(len(q))])
    np.testing.assert_allclose(tau, ref + 0.4 * qd + 1.2 * np.sign(qd) + off, atol=1e-10)
    H = robot.energy(q, qd) - robot.energy(q, np.zeros_like(qd))
    K = [pin.computeKineticEnergy(model, data, q[k], qd[k]) for k in range(len(q))]
    np.testing.assert_allclose(H, K, atol=1e-10)  # pinocchio's kinetic energy includes Ia qd^2 / 2
    np.testing.assert_allclose(robot.forward_dynamics(q, qd, tau), qdd, atol=1e-9)
    with pytest.raises(InputError, match="with_armature"):
        UrdfRobot("ur5", armature=0.1)


def test_continuous_joints_use_cos_sin_configuration():
    """Kinova (three continuous joints): angles become pinocchio's (cos, sin) pairs; Y theta = RNEA."""
    robot = UrdfRobot("kinova")
    assert robot.joint_kinds.count("continuous") == 3 and np.isinf(robot.limits.upper[0])
    model = pin.buildModelFromUrdf(str(robot.urdf_path))
    data = model.createData()
    q, qd, qdd = states(robot, N=10)
    for k in range(len(q)):
        config = []
        for j in range(robot.n_joints):
            config += [np.cos(q[k, j]), np.sin(q[k, j])] if model.nqs[j + 1] == 2 else [q[k, j]]
        tau = pin.rnea(model, data, np.array(config), qd[k], qdd[k])
        np.testing.assert_allclose(robot.regressor(q[k], qd[k], qdd[k])[:, :60] @ robot.theta_true[:60], tau,
                                   atol=1e-10)


def test_prismatic_joint_and_mimic_joint():
    """The Panda file as a path: its mimic finger joint is left out, the other finger is a prismatic joint
    (units N s/m, N), and Y theta = RNEA of pinocchio's model with the mimic joint locked."""
    robot = UrdfRobot(example_robots_dir() / EXAMPLE_ROBOTS["panda"][0])
    assert robot.joint_names[-1] == "panda_finger_joint1" and robot.joint_kinds[-1] == "prismatic"
    assert robot.param_units[robot.param_names.index("fv8")] == "N s/m"
    full = pin.buildModelFromUrdf(str(robot.urdf_path))
    model = pin.buildReducedModel(full, [full.getJointId("panda_finger_joint2")], pin.neutral(full))
    data = model.createData()
    q, qd, qdd = states(robot, N=10)
    ref = np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(len(q))]) + friction(robot, qd)
    np.testing.assert_allclose(robot.inverse_dynamics(q, qd, qdd), ref, atol=1e-10)


def test_limits_read_from_the_urdf(robots):
    """UR5 limits as in its URDF (efforts 150/28 N m, velocities 3.15/3.2 rad/s), accelerations by the stated rule."""
    lim = robots["ur5"].limits
    np.testing.assert_array_equal(lim.effort, [150, 150, 150, 28, 28, 28])
    np.testing.assert_array_equal(lim.velocity, [3.15, 3.15, 3.15, 3.2, 3.2, 3.2])
    np.testing.assert_allclose(lim.acceleration, 5.0 * lim.velocity)
    np.testing.assert_allclose(lim.upper[2], np.pi)
    assert UrdfRobot("ur5", acceleration_limit=2.0).limits.acceleration.tolist() == [2.0] * 6
    assert robots["panda"].joint_names == tuple(f"panda_joint{i}" for i in range(1, 8))


# -- bad input ---------------------------------------------------------------------------------
LINK = '<link name="{0}"><inertial><mass value="1"/><inertia ixx="{1}" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>' \
       '</inertial></link>'
JOINT = '<joint name="{0}" type="{3}"><parent link="{1}"/><child link="{2}"/><axis xyz="0 0 1"/>' \
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'


def write(tmp_path, body, name="r.urdf"):
    path = tmp_path / name
    path.write_text(f'<robot name="r"><link name="base"/>{body}</robot>')
    return path


@pytest.mark.parametrize("body, match", [
    (LINK.format("a", 1) + JOINT.format("free", "base", "a", "floating"), "floating base"),
    (LINK.format("a", 1) + LINK.format("b", 1) + JOINT.format("ja", "base", "a", "revolute")
     + JOINT.format("jb", "base", "b", "revolute"), "serial chain"),
    (LINK.format("a", 1) + LINK.format("b", 1) + JOINT.format("ja", "base", "a", "revolute")
     + JOINT.format("jb", "a", "b", "revolute") + JOINT.format("jc", "base", "b", "revolute"), "closed kinematic"),
    (LINK.format("a", "abc") + JOINT.format("ja", "base", "a", "revolute"), "ixx='abc'"),
])
def test_unsupported_urdfs_are_refused(tmp_path, body, match):
    """Floating base, branching tree, closed loop, malformed number: an InputError that names the problem."""
    with pytest.raises(InputError, match=match):
        UrdfRobot(write(tmp_path, body))


def test_unknown_names_and_files(tmp_path):
    with pytest.raises(InputError, match="ur5"):
        UrdfRobot("ur6")
    with pytest.raises(InputError, match="not found"):
        UrdfRobot(tmp_path / "missing.urdf")
    with pytest.raises(InputError, match="unknown"):
        UrdfRobot("ur5", joints=["elbow"])
    branch = write(tmp_path, LINK.format("a", 1) + LINK.format("b", 1) + JOINT.format("ja", "base", "a", "revolute")
                   + JOINT.format("jb", "base", "b", "revolute"))
    assert UrdfRobot(branch, joints=["jb"]).joint_names == ("jb",)  # one branch selected: serial


# -- base parameters -------------------------------------------------------------------------
@pytest.mark.parametrize("name, rank", [("ur5", 36 + 12), ("panda", 43 + 14)])
def test_base_parameters(robots, bases, name, rank):
    """Rank by pivoted QR = numpy SVD rank at other states; Y P1 (K theta) = Y theta (1e-10 N m); K P1 = I."""
    robot, base = robots[name], bases[name]
    q, qd, qdd = states(robot, N=150, seed=7)
    W = robot.regressor(q, qd, qdd).reshape(-1, robot.p)
    assert base.rank == rank == np.linalg.matrix_rank(W)
    assert base.gap[0] > 1e-3 and base.gap[1] < 1e-13
    view = BaseParameterModel(robot, base)
    np.testing.assert_allclose(view.inverse_dynamics(q, qd, qdd), robot.inverse_dynamics(q, qd, qdd), atol=1e-10)
    np.testing.assert_array_equal(base.K[:, base.independent], np.eye(base.rank))
    beta = view.theta_true * 1.1
    np.testing.assert_allclose(base.base(base.standard(beta, robot.theta_true)), beta, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(view.mass_matrix(q[:3], beta), robot.mass_matrix(q[:3], view.standard(beta)))


def test_ur5_regrouping_matches_the_closed_form(robots, bases):
    """UR5 joints 2-4 are parallel, 0.425 m apart (URDF): Khalil's rules put a2^2 (m3 + ... + m6) into the link-2
    inertia about the axis and a2 (m3 + ... + m6) into its first moment along the link."""
    robot, base = robots["ur5"], bases["ur5"]
    names = base.names
    row = next(i for i, nm in enumerate(names) if nm.startswith("Iyy2 "))
    assert names[row] == "Iyy2 + 0.1806 m3 + 0.1806 m4 + 0.1806 m5 + 0.1806 m6"
    masses = [robot.param_names.index(f"m{j}") for j in range(3, 7)]
    np.testing.assert_allclose(base.K[row, masses], 0.425 ** 2, rtol=1e-12)
    row = next(i for i, nm in enumerate(names) if nm.startswith("mz2 "))
    np.testing.assert_allclose(base.K[row, masses], 0.425, rtol=1e-12)
    assert base.units[row] == "kg m" and "fv1" in names and "fc6" in names


def test_base_model_regressors_and_prior(robots, bases):
    """The base view's momentum/remainder are the standard ones' columns; its energy differs by a constant only;
    an unknown (NaN) standard prior makes only the base parameters that involve it unknown."""
    robot, base = robots["ur5"], bases["ur5"]
    view = BaseParameterModel(robot, base)
    q, qd, _ = states(robot, N=10)
    np.testing.assert_allclose(view.momentum_regressor(q, qd) @ view.theta_true,
                               robot.momentum_regressor(q, qd) @ robot.theta_true, atol=1e-12)
    np.testing.assert_allclose(view.remainder_regressor(q, qd) @ view.theta_true,
                               robot.remainder_regressor(q, qd) @ robot.theta_true, atol=1e-10)
    gap = view.energy(q, qd) - robot.energy(q, qd)
    assert np.ptp(gap) < 1e-10
    robot_nan = UrdfRobot("ur5")
    robot_nan.theta_prior = robot_nan.theta_prior.copy()
    robot_nan.theta_prior[robot_nan.param_names.index("m6")] = np.nan
    prior = BaseParameterModel(robot_nan, base).theta_prior
    involves = base.K[:, robot_nan.param_names.index("m6")] != 0
    assert np.all(np.isnan(prior[involves])) and np.all(np.isfinite(prior[~involves]))


def test_base_parameters_of_the_direct_drive_arm_are_its_own():
    """The arm's 9 parameters are identifiable: rank 9, K = identity, names unchanged."""
    arm = DirectDriveArm()
    base = base_parameters(arm)
    np.testing.assert_array_equal(base.K, np.eye(9))
    assert base.names == arm.param_names


# -- a 2-link URDF against the built-in direct-drive arm ---------------------------------------
@pytest.fixture
def planar(tmp_path):
    robot = UrdfRobot(planar_arm_urdf(tmp_path), gravity=[0.0, 0.0, -PHYSICAL["g"]])
    return robot, BaseParameterModel(robot)


def test_planar_urdf_matches_the_direct_drive_arm(planar):
    """Same torques, mass matrix, energy (up to its constant) as DirectDriveArm, and the base parameters map onto
    the arm's 9 by its closed form: th1 = (Ixx1 + l1^2 m2) + Ixx2, th2 = -l1 mz2, th3 = Ixx2,
    th4 = -g (mz1 - l1 m2), th5 = -g mz2, friction one to one. The two other base parameters (COM off the link
    axis, my1 and my2) do not exist in the arm's model and are 0 in the URDF."""
    robot, view = planar
    arm, P = DirectDriveArm(), PHYSICAL
    rng = np.random.default_rng(3)
    q, qd, qdd = rng.uniform(-3, 3, (100, 2)), rng.normal(0, 3, (100, 2)), rng.normal(0, 20, (100, 2))
    np.testing.assert_allclose(view.inverse_dynamics(q, qd, qdd), arm.inverse_dynamics(q, qd, qdd), atol=1e-10)
    np.testing.assert_allclose(view.mass_matrix(q), arm.mass_matrix(q), atol=1e-12)
    assert np.ptp(view.energy(q, qd) - arm.energy(q, qd)) < 1e-10
    names = view.param_definitions
    assert names == ("my1", "mz1 - 0.45 m2", "Ixx1 + 0.2025 m2", "my2", "mz2", "Ixx2", "fv1", "fv2", "fc1", "fc2")
    assert view.param_names == ("my1", "mz1R", "Ixx1R", "my2", "mz2", "Ixx2", "fv1", "fv2", "fc1", "fc2")
    i = {nm.split()[0]: k for k, nm in enumerate(names)}
    A = np.zeros((9, 10))
    A[0, [i["Ixx1"], i["Ixx2"]]] = 1.0
    A[1, i["mz2"]] = -P["l1"]
    A[2, i["Ixx2"]] = 1.0
    A[3, i["mz1"]] = A[4, i["mz2"]] = -P["g"]
    A[5:, 6:] = np.eye(4)
    on_axis = [k for k in range(10) if k not in (i["my1"], i["my2"])]
    Y_arm = arm.regressor(q, qd, qdd).reshape(-1, 9)
    Y_urdf = view.regressor(q, qd, qdd).reshape(-1, 10)
    np.testing.assert_allclose(Y_arm @ A[:, on_axis], Y_urdf[:, on_axis], atol=1e-10)
    np.testing.assert_allclose(A @ view.theta_true, arm.theta_true, rtol=1e-12)
    assert view.theta_true[i["my1"]] == 0.0 and view.theta_true[i["my2"]] == 0.0


def test_planar_urdf_simulates_like_the_arm_and_is_identified(planar):
    """Open loop under the paper's torques (31)-(32) for 3 s: the URDF (ABA) and the closed-form arm follow the same
    path (1e-8 rad); least squares on the inverse dynamic model (rows of the joints moving faster than 0.1 rad/s,
    where the simulated tanh Coulomb equals sign) recovers every base parameter within 1 % (zero ones within 1e-9)."""
    robot, view = planar
    torque = RampedMultisine.direct_drive_paper()
    sim = simulate_open_loop(view, torque, 3.0, 2.5e-3)
    ref = simulate_open_loop(DirectDriveArm(), torque, 3.0, 2.5e-3)
    assert sim.info["fast_path"] and np.abs(sim.q - ref.q).max() < 1e-8
    R = inverse_dynamic(view, sim.q, sim.qd, sim.qdd, sim.tau, sim.t).subset(np.abs(sim.qd).ravel() > 0.1)
    beta = np.linalg.lstsq(R.W, R.y, rcond=None)[0]
    assert np.all(np.abs(beta - view.theta_true) <= 0.01 * np.abs(view.theta_true) + 1e-9)


# -- excitation within the limits --------------------------------------------------------------
def test_fourier_trajectory_within_the_limits(robots, bases):
    """Random rest-to-rest trajectory for the UR5, sampled at 1 kHz: inside the limits shrunk by 10 % everywhere,
    at rest at both ends, and as large as allowed (one limit within 5 % of reached)."""
    view = BaseParameterModel(robots["ur5"], bases["ur5"])
    traj = fourier_within_limits(view, np.random.default_rng(0), period=6.0, harmonics=5)
    t = np.arange(0.0, traj.duration, 1e-3)
    use = limit_usage(view, *traj.evaluate(t), margin=0.1)
    assert use["position"] == 0.0 and max(use["velocity"], use["acceleration"], use["effort"]) <= 1.0
    assert max(use["velocity"], use["acceleration"]) > 0.95
    q, qd, qdd = traj.evaluate(np.array([0.0, traj.duration]))
    assert np.abs(qd).max() < 1e-9 and np.abs(qdd).max() < 1e-9
    np.testing.assert_allclose(q[0], robots["ur5"].limits.middle(), atol=1e-12)


def test_optimised_trajectory_lowers_the_condition_number(planar):
    """optimize_trajectory (the suite's optimiser) with the joint limits as a barrier: the column-scaled condition
    number of the base regressor does not rise and the result stays within the limits."""
    robot, view = planar
    traj = fourier_within_limits(view, np.random.default_rng(2), period=4.0, harmonics=4)
    best, info = optimize_within_limits(view, traj, max_evals=60)
    assert info["cond_after"] <= info["cond_before"]
    t = np.arange(0.0, best.duration, 1e-3)
    use = limit_usage(view, *best.evaluate(t), margin=0.1)
    assert use["position"] == 0.0 and max(use["velocity"], use["acceleration"], use["effort"]) <= 1.0


def test_excitation_needs_limits_and_base_parameters(robots):
    with pytest.raises(InputError, match="no joint limits"):
        fourier_within_limits(DirectDriveArm(), np.random.default_rng(0))
    with pytest.raises(InputError, match="velocity_limit"):
        fourier_within_limits(UrdfRobot("double_pendulum"), np.random.default_rng(0))
    traj = fourier_within_limits(robots["ur5"], np.random.default_rng(0), period=4.0)
    with pytest.raises(InputError, match="BaseParameterModel"):
        optimize_within_limits(robots["ur5"], traj, max_evals=1)
    away = FourierTrajectory(4.0, [0.0, 0.0, 3.0, 0.0, 0.0, 0.0], np.ones((6, 3)), np.ones((6, 3)))
    with pytest.raises(InputError, match="rest position"):
        fit_to_limits(robots["ur5"], SegmentedTrajectory((away,), (1,)))


# -- all four regression models on exact states ------------------------------------------------
@pytest.mark.parametrize("builder", [filtered_dynamic, supplied_energy, filtered_power])
def test_regression_models_hold_with_the_base_truth(robots, bases, builder):
    """On exact samples of an analytic motion starting at rest (2 kHz, 2 s), the filtered dynamic, supplied energy
    and filtered power regressions of the UR5 in base parameters hold with the base truth to their
    discretisation error (relative rms residual < 1e-4)."""
    view = BaseParameterModel(robots["ur5"], bases["ur5"])
    t = np.arange(0.0, 2.0, 5e-4)
    q, qd, qdd = analytic_motion(6, t[:, None])
    tau = view.inverse_dynamics(q, qd, qdd)
    R = builder(view, q, qd, tau, t)
    res = R.y - R.W @ view.theta_true
    assert np.sqrt(np.mean(res ** 2)) < 1e-4 * np.sqrt(np.mean(R.y ** 2))


# -- export ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ARMS)
def test_urdf_export_round_trip(robots, tmp_path, name):
    """Written into a copy of the URDF and read back: the URDF truth and a changed theta (heavier bodies, other
    friction) come back to 1e-12. The Panda's hand and fingers (merged into link 7) keep their own values."""
    robot = robots[name]
    out = write_urdf(robot, robot.theta_true, tmp_path / "truth.urdf")
    np.testing.assert_allclose(UrdfRobot(out, joints=robot.joint_names).theta_true, robot.theta_true, atol=1e-12)
    n = robot.n_joints
    theta = robot.theta_true.copy()
    theta[:10 * n] *= np.repeat(1.0 + 0.1 * np.arange(1, n + 1), 10)
    theta[10 * n:] = np.linspace(0.1, 2.0, 2 * n)
    back = UrdfRobot(write_urdf(robot, theta, tmp_path / "new.urdf"), joints=robot.joint_names)
    np.testing.assert_allclose(back.theta_true, theta, atol=1e-12)
    with pytest.raises(InputError, match="overwrite"):
        write_urdf(robot, theta, robot.urdf_path)
    bad = theta.copy()
    bad[0] = -1.0
    with pytest.raises(InputError, match="positive mass"):
        write_urdf(robot, bad, tmp_path / "bad.urdf")


def test_parameter_tables(robots, bases, tmp_path):
    """CSV and YAML hold the standard and base values with names and units, exactly."""
    robot, base = robots["ur5"], bases["ur5"]
    csv = pd.read_csv(write_parameters(robot, robot.theta_true, tmp_path / "p.csv", base))
    assert list(csv.columns) == ["set", "name", "unit", "value"]
    std = csv[csv.set == "standard"]
    np.testing.assert_array_equal(std.value, robot.theta_true)
    assert tuple(std.name) == robot.param_names and tuple(std.unit) == robot.param_units
    np.testing.assert_array_equal(csv[csv.set == "base"].value, base.base(robot.theta_true))
    doc = yaml.safe_load(write_parameters(robot, robot.theta_true, tmp_path / "p.yaml", base).read_text())
    assert doc["robot"] == "ur5" and len(doc["base"]) == base.rank
    assert [r["value"] for r in doc["standard"]] == robot.theta_true.tolist()
    assert doc["base"][0]["name"] == base.names[0]
    assert len(parameter_table(robot, robot.theta_true)) == robot.p
    with pytest.raises(InputError, match="csv"):
        write_parameters(robot, robot.theta_true, tmp_path / "p.txt")


# -- identification from simulated data (slow) -----------------------------------------------
def tracked_run(view, duration, seed=0, h=1e-3):
    """Computed torque + PD tracking a random exciting trajectory, simulated with ABA (zero-order hold)."""
    traj = fourier_within_limits(view, np.random.default_rng(seed), period=duration, harmonics=5)
    kp, kd = 400.0, 40.0

    def torque(tk, q, qd):
        qr, vr, ar = traj.evaluate(np.array([tk]))
        a = ar[0] + kp * (qr[0] - q) + kd * (vr[0] - qd)
        return view.inverse_dynamics(q[None], qd[None], a[None])[0]
    return simulate_sampled(view, torque, duration, h, q0=traj.segments[0].q0, coulomb_width=0.01)


@pytest.mark.slow  # ~15-30 s each: 4000 hold intervals integrated with ABA
@pytest.mark.parametrize("name", ARMS)
def test_base_parameters_recovered_from_simulated_data(robots, bases, name):
    """Noise-free closed-loop simulation (4 s at 1 kHz): least squares on the inverse dynamic model (rows of the
    joints moving faster than 0.1 rad/s, where the simulated tanh Coulomb equals sign) recovers every base
    parameter within 1 % (zero ones within 1e-8)."""
    view = BaseParameterModel(robots[name], bases[name])
    sim = tracked_run(view, 4.0)
    R = inverse_dynamic(view, sim.q, sim.qd, sim.qdd, sim.tau, sim.t).subset(np.abs(sim.qd).ravel() > 0.1)
    beta = np.linalg.lstsq(R.W, R.y, rcond=None)[0]
    assert np.all(np.abs(beta - view.theta_true) <= 0.01 * np.abs(view.theta_true) + 1e-8)


@pytest.mark.slow  # ~15 s
def test_filtered_dynamic_model_on_simulated_ur5():
    """Without Coulomb friction (whose tanh/sign mismatch at velocity reversals the filters cannot drop), the
    filtered dynamic model on the simulated UR5 (no qdd, midpoint pairing, Tustin) recovers the base parameters
    larger than 1e-3 of the largest within 1 %."""
    view = BaseParameterModel(UrdfRobot("ur5", viscous=0.5, coulomb=0.0))
    sim = tracked_run(view, 4.0)
    a = align(sim.q, sim.tau, 1e-3)
    R = filtered_dynamic(view, a.q, a.qd, a.tau, a.t)
    beta = np.linalg.lstsq(R.W, R.y, rcond=None)[0]
    big = np.abs(view.theta_true) > 1e-3 * np.abs(view.theta_true).max()
    assert np.all(np.abs(beta - view.theta_true)[big] <= 0.01 * np.abs(view.theta_true[big]))
