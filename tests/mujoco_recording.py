"""A recording of a URDF arm simulated by MuJoCo, an engine independent of boundid, with its truth.

Test helper (MuJoCo is a test dependency; nothing under src/ imports it). :func:`record` loads a URDF
arm of example-robot-data into MuJoCo, adds seeded joint friction and armature, tracks a seeded
Fourier reference in closed loop with ``mj_step`` and returns what a robot's controller would log
(encoder angles, measured torques at 1 kHz) with the truth an identification must explain.

The simulated arm (:func:`load_arm`): the URDF with its <visual> and <collision> elements removed
(no geometry, hence no contact; contact and joint-limit constraints are disabled too), the joints
left out of ``joints`` made fixed, and MuJoCo's URDF compiler options ``fusestatic`` (links joined
by fixed joints merged into one body, as pinocchio does), ``discardvisual`` and
``inertiafromgeom="false"`` (the <inertial> of the file). Per joint j, seeded values of:

    damping        viscous friction fv_j [N m s/rad]: qfrc_passive = -fv_j qd_j
    frictionloss   dry friction of at most fc_j [N m]: MuJoCo's soft friction constraint, which
                   sticks, creeps and slips, unlike the identification model's fc_j sign(qd_j)
    armature       rotor inertia Ia_j [kg m^2] added to M(q)_jj

The experiment (:func:`record`): a rest-to-rest Fourier reference within the URDF's position,
velocity and acceleration limits (boundid's :func:`fourier_within_limits`, only to draw the
reference), tracked at 1 kHz by the reference's inverse dynamics (``mj_inverse`` on the arm without
its dry friction: rigid bodies, armature and damping) plus a joint PD on the encoder angles and a
filtered difference of them; the torque is held for ``substeps`` RK4 steps. Measured: 16-bit
encoder angles and the applied torque plus Gaussian noise. The torque logged at t_k is the one held
until t_(k+1), as a controller logs its command, while a central-difference acceleration at t_k spans
both holds around t_k: an inverse-dynamic row sees about h/2 dtau/dt of model error (measured on the
six-joint UR5, seeds 2 and 6, without dry friction, exact encoders, rows low-passed at 10 Hz: up to
0.12-0.16 N m on the shoulder, below 0.01 N m against the mean of the two holds).

The truth, in boundid's parameterisation of the same URDF (:class:`boundid.models.urdf.UrdfRobot`
with ``with_armature=True``: 10 inertial parameters per body, then Ia, fv, fc): per body,
m = ``body_mass``, c = ``body_ipos`` and I_C = R diag(``body_inertia``) R^T with R the rotation of
``body_iquat``, all in the MuJoCo body frame, which is the URDF child link frame at the joint's origin,
pinocchio's joint frame (:func:`true_theta` checks that each joint sits at its body's origin); the
inertia about that origin I = I_C + m S(c)^T S(c), listed as m, m c, Ixx, Ixy, Iyy, Ixz, Iyz, Izz.
Ia_j = armature, fv_j = damping, fc_j = frictionloss.
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import mujoco
import numpy as np

from boundid.experiments.limited_trajectories import fourier_within_limits
from boundid.experiments.recording import Recording
from boundid.models.urdf import UrdfRobot, resolve_urdf

#: The UR5's positioning joints (the wrist fixed at 0).
UR5_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint")

#: All six joints of the UR5 (52 base parameters with armature, against 22 for :data:`UR5_JOINTS`). The
#: reference keeps within the URDF's limits of every joint (wrist: +-2 pi rad, 3.2 rad/s, 16 rad/s^2, 28 N m);
#: measured on seeds 0-4: the wrist joints sweep 0.6-2.0 rad at up to 0.9 of their velocity limit and need
#: at most 10 N m, of which their dry friction (drawn like the other joints') is 0.15-0.8 of the RMS torque.
UR5_ALL_JOINTS = UR5_JOINTS + ("wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


@dataclass(frozen=True)
class MujocoRecording:
    """A MuJoCo closed-loop run of N samples of an n-joint arm, and its truth.

    t (N,) s; q (N, n) rad, 16-bit encoder angles; tau (N, n) N m, measured torque (applied + noise);
    tau_applied (N, n) N m, the torque applied to the joints (the truth the model must explain);
    q_true, qd_true, qdd_true (N, n): MuJoCo's state at each sample and its acceleration under the
    applied torque [rad, rad/s, rad/s^2]; theta_true (p,) in ``robot``'s parameter order;
    viscous, dry, armature (n,): the joints' damping [N m s/rad], frictionloss [N m] and armature
    [kg m^2]; robot : the identification model (UrdfRobot of the same URDF and joints, with
    armature); model : the simulated MjModel.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    tau_applied: np.ndarray
    q_true: np.ndarray
    qd_true: np.ndarray
    qdd_true: np.ndarray
    theta_true: np.ndarray
    viscous: np.ndarray
    dry: np.ndarray
    armature: np.ndarray
    robot: UrdfRobot
    model: mujoco.MjModel

    def recording(self) -> Recording:
        """What the robot logs: t, encoder angles and measured torques (boundid's measured format)."""
        return Recording(t=self.t, q=self.q, tau=self.tau)


def mujoco_urdf(source: str, joints: tuple[str, ...]) -> str:
    """URDF text for MuJoCo: ``source`` (an example-robot-data name or a path) without visual and
    collision elements, every joint not in ``joints`` fixed, and MuJoCo's compiler options."""
    path, _, _ = resolve_urdf(source)
    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for tag in ("visual", "collision"):
            for element in link.findall(tag):
                link.remove(element)
    for joint in root.iter("joint"):
        if joint.get("name") not in joints:
            joint.set("type", "fixed")
    compiler = ET.SubElement(ET.SubElement(root, "mujoco"), "compiler")
    compiler.attrib.update(fusestatic="true", discardvisual="true", inertiafromgeom="false")
    return ET.tostring(root, encoding="unicode")


def load_arm(source: str = "ur5", joints: tuple[str, ...] = UR5_JOINTS, viscous=0.0, dry=0.0, armature=0.0,
             timestep: float = 2.5e-4) -> mujoco.MjModel:
    """The arm in MuJoCo, joint friction and armature set ((n,) or scalars), RK4 at ``timestep`` s,
    contact and joint limits disabled, the constraint solver (the dry friction) run to round-off
    (its default tolerance leaves ~1e-4 N m in the friction force)."""
    model = mujoco.MjModel.from_xml_string(mujoco_urdf(source, joints))
    names = tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt))
    if names != tuple(joints):
        raise ValueError(f"MuJoCo's joints {names} are not {joints} in chain order")
    model.dof_damping[:] = viscous
    model.dof_frictionloss[:] = dry
    model.dof_armature[:] = armature
    model.opt.timestep = timestep
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.tolerance, model.opt.iterations = 1e-12, 200
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    return model


def true_theta(model: mujoco.MjModel, robot: UrdfRobot) -> np.ndarray:
    """theta (p,) of ``model`` in ``robot``'s parameter order (module docstring): inertial parameters
    of the body each joint moves, then Ia, fv, fc from armature, damping and frictionloss."""
    n = robot.n_joints
    theta = np.zeros(robot.p)
    for j in range(n):
        b = int(model.jnt_bodyid[j])
        if np.any(model.jnt_pos[j] != 0) or model.body_jntnum[b] != 1:
            raise ValueError(f"joint {j} is not alone at the origin of its body: the frames differ from boundid's")
        m, c = model.body_mass[b], model.body_ipos[b]
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, model.body_iquat[b])
        R = R.reshape(3, 3)
        S = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
        inertia = R @ np.diag(model.body_inertia[b]) @ R.T + m * S.T @ S
        theta[10 * j:10 * j + 10] = [m, *(m * c), inertia[0, 0], inertia[0, 1], inertia[1, 1], inertia[0, 2],
                                     inertia[1, 2], inertia[2, 2]]
    index = {name: k for k, name in enumerate(robot.param_names)}
    for key, values in (("Ia", model.dof_armature), ("fv", model.dof_damping), ("fc", model.dof_frictionloss)):
        for j in range(n):
            theta[index[f"{key}{j + 1}"]] = values[j]
    return theta


def inverse_forces(model: mujoco.MjModel, q, qd, qdd) -> np.ndarray:
    """MuJoCo's ``mj_inverse`` joint forces (N, n) [N m] at the states q, qd, qdd (N, n): M qdd + bias
    - passive (damping) - constraint forces of the model's own friction, if any."""
    data = mujoco.MjData(model)
    out = np.empty_like(np.asarray(q, float))
    for k in range(out.shape[0]):
        data.qpos[:], data.qvel[:], data.qacc[:] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(model, data)
        out[k] = data.qfrc_inverse
    return out


def without_dry_friction(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of ``model`` with frictionloss 0 (rigid bodies, armature and damping only)."""
    smooth = copy.copy(model)
    smooth.dof_frictionloss[:] = 0.0
    return smooth


def record(source: str = "ur5", joints: tuple[str, ...] = UR5_JOINTS, seed: int = 0, duration_s: float = 15.0,
           fs_hz: float = 1000.0, substeps: int = 4, period_s: float = 5.0, harmonics: int = 5,
           bandwidth_hz: float = 3.0, velocity_filter_hz: float = 30.0, counts_per_rev: int = 65536,
           torque_noise: float = 0.1) -> MujocoRecording:
    """A seeded MuJoCo tracking run of ``source`` (module docstring) and its truth.

    seed : every draw (friction, armature, reference, torque noise) from numpy's default_rng(seed);
    duration_s, fs_hz : length [s] and sample/control rate [Hz]; substeps : RK4 steps per sample;
    period_s, harmonics : the Fourier reference (repeated to cover duration_s); bandwidth_hz : joint
    PD bandwidth from the diagonal of M at the start; velocity_filter_hz : first-order low-pass of
    the encoder difference fed to the D term; counts_per_rev : encoder; torque_noise : N m, standard
    deviation of the Gaussian noise on the measured torque. Drawn per joint: viscous U(0.5, 2) N m
    s/rad, dry U(0.5, 2) N m, armature U(0.05, 0.3) kg m^2.
    """
    rng = np.random.default_rng(seed)
    robot = UrdfRobot(source, joints, with_armature=True)
    n, h = robot.n_joints, 1.0 / fs_hz
    viscous, dry, armature = rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n), rng.uniform(0.05, 0.3, n)
    model = load_arm(source, joints, viscous, dry, armature, h / substeps)
    repeats = int(np.ceil(duration_s / period_s))
    reference = fourier_within_limits(robot, rng, period_s, harmonics, repeats)
    t = np.arange(int(round(duration_s * fs_hz))) * h
    q_ref, qd_ref, qdd_ref = reference.evaluate(t)
    smooth = without_dry_friction(model)
    feedforward = inverse_forces(smooth, q_ref, qd_ref, qdd_ref)

    data = mujoco.MjData(model)
    data.qpos[:] = q_ref[0]
    mujoco.mj_forward(model, data)
    mass = np.empty((n, n))
    mujoco.mj_fullM(model, data, mass)
    w = 2.0 * np.pi * bandwidth_hz
    kp, kd = np.diag(mass) * w ** 2, 2.0 * np.diag(mass) * w
    resolution = 2.0 * np.pi / counts_per_rev
    alpha = np.exp(-2.0 * np.pi * velocity_filter_hz * h)

    N = t.size
    q_true, qd_true, qdd_true, q_meas, tau = (np.empty((N, n)) for _ in range(5))
    q_last, speed = np.round(q_ref[0] / resolution) * resolution, np.zeros(n)
    for k in range(N):
        q_true[k], qd_true[k] = data.qpos, data.qvel
        q_meas[k] = np.round(data.qpos / resolution) * resolution
        speed = alpha * speed + (1.0 - alpha) * (q_meas[k] - q_last) / h
        q_last = q_meas[k]
        tau[k] = feedforward[k] + kp * (q_ref[k] - q_meas[k]) + kd * (qd_ref[k] - speed)
        data.qfrc_applied[:] = tau[k]
        mujoco.mj_forward(model, data)
        qdd_true[k] = data.qacc
        for _ in range(substeps):
            mujoco.mj_step(model, data)
    noisy = tau + rng.normal(0.0, torque_noise, tau.shape)
    return MujocoRecording(t, q_meas, noisy, tau, q_true, qd_true, qdd_true, true_theta(model, robot), viscous,
                           dry, armature, robot, model)
