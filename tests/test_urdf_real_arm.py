"""What a real arm needs in its URDF model: a coupled motor (the Staubli TX40's wrist) and per-joint
friction, armature and offset values, in the Python API and in a study file.

References, independent of the code under test: the transmission matrix of the TX40 built here from
FIGAROH's configuration (studies/data/tx40/T40X_config.yaml, read with yaml: R = diag(N) and
R[5, 4] = N[5], q_m = R q) and the motor's own equation in motor-side units, tau_m = J qdd_m + b qd_m +
c sign(qd_m), mapped to the joints by virtual work, tau = R^T tau_m; FIGAROH's own form of the TX40's
coupled wrist (its regressor puts Iam6 qdd6 + fvm6 qd6 + fsm6 sign(qd5 + qd6) on joint 5 and Iam6 qdd5 +
fvm6 qd5 + fsm6 sign(qd5 + qd6) on joint 6, its Ia and fv carrying the diagonal terms); pinocchio's RNEA
and CRBA on a model built here from the file; central finite differences in time of the energy and of
the momentum along an analytic motion; a Taylor step of the state for the ZOH stepper.
"""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

from boundid.errors import InputError, StudyError
from boundid.models.base_parameters import base_parameters
from boundid.models.urdf import UrdfRobot
from boundid.studies.config import load_study

DATA = Path(__file__).resolve().parents[1] / "studies" / "data" / "tx40"
URDF = DATA / "tx40_mdh_modified.urdf"
# YAML 1.1 reads 8.05e0 (no sign in the exponent) as a string, as FIGAROH does: float() every value
FIGAROH = {k: np.asarray(v, float) for k, v in yaml.safe_load((DATA / "T40X_config.yaml").read_text())[
    "identification"]["robot_params"][0].items() if k in ("fv", "fs", "Ia", "offset", "Iam6", "fvm6", "fsm6", "N")}
N = FIGAROH["N"]                                       # gear ratios [32, 32, 45, -48, 45, 32]
IAM6, FVM6, FSM6 = float(FIGAROH["Iam6"]), float(FIGAROH["fvm6"]), float(FIGAROH["fsm6"])
WRIST = {"motor": 6, "joints": [5, 6], "ratios": [N[5], N[5]], "armature": IAM6, "viscous": FVM6, "coulomb": FSM6}


def transmission() -> np.ndarray:
    """R (6, 6): q_m = R q, motor 6 turning with q5 + q6 (the TX40's wrist)."""
    R = np.diag(N)
    R[5, 4] = N[5]
    return R


def figaroh_to_ours(values, coupled) -> np.ndarray:
    """FIGAROH's Ia or fv of the TX40 include the coupled motor's diagonal terms on joints 5 and 6: remove them."""
    v = np.array(values, float)
    v[4:6] -= coupled
    return v


@pytest.fixture(scope="module")
def tx40():
    """The TX40 with FIGAROH's friction, drive inertias, offsets and coupled wrist (our convention)."""
    return UrdfRobot(URDF, viscous=figaroh_to_ours(FIGAROH["fv"], FVM6), coulomb=FIGAROH["fs"], with_armature=True,
                     armature=figaroh_to_ours(FIGAROH["Ia"], IAM6), with_offset=True, offset=FIGAROH["offset"],
                     coupled_motors=[WRIST])


@pytest.fixture(scope="module")
def plain(tx40):
    """The same TX40 without its coupled motor."""
    th = tx40.theta_true
    return UrdfRobot(URDF, viscous=th[tx40._slices["fv"]], coulomb=th[tx40._slices["fc"]], with_armature=True,
                     armature=th[tx40._slices["Ia"]], with_offset=True, offset=th[tx40._slices["off"]])


def states(robot, N_=20, seed=3):
    rng = np.random.default_rng(seed)
    lim = robot.limits
    return (lim.sample_positions(rng, N_), rng.uniform(-1, 1, (N_, 6)) * lim.velocity,
            rng.uniform(-1, 1, (N_, 6)) * lim.acceleration)


def motion(t):
    """Smooth q, qd, qdd of the 6 joints at time t (incommensurate frequencies; qd5 + qd6 changes sign)."""
    w = np.linspace(0.8, 2.3, 6)
    return 0.4 * np.sin(w * t) + 0.1, 0.4 * w * np.cos(w * t), -0.4 * w * w * np.sin(w * t)


def column(robot, name) -> np.ndarray:
    e = np.zeros(robot.p)
    e[robot.param_names.index(name)] = 1.0
    return e


# -- the coupled motor's torques -----------------------------------------------------------------
def test_parameters_names_units_and_values(tx40):
    assert tx40.p == 6 * 10 + 4 * 6 + 3
    assert tx40.param_names[-3:] == ("Iam6", "fvm6", "fsm6")
    assert tx40.param_units[-3:] == ("kg m^2", "N m s/rad", "N m")
    np.testing.assert_array_equal(tx40.theta_true[-3:], [IAM6, FVM6, FSM6])


def test_coupled_motor_torque_is_r_transpose_of_the_motor_torque(tx40, plain):
    """Y theta = the arm without the motor + R^T tau_m, tau_m = J qdd_m + b qd_m + c sign(qd_m) on motor 6's
    row only, motor-side J = Iam6 / N6^2, b = fvm6 / N6^2, c = fsm6 / N6; each new column alone, too."""
    q, qd, qdd = states(tx40)
    R = transmission()
    qd_m, qdd_m = qd @ R.T, qdd @ R.T
    n6 = N[5]
    tau_m = np.zeros_like(qd)
    tau_m[:, 5] = IAM6 / n6 ** 2 * qdd_m[:, 5] + FVM6 / n6 ** 2 * qd_m[:, 5] + FSM6 / n6 * np.sign(qd_m[:, 5])
    ref = plain.inverse_dynamics(q, qd, qdd) + tau_m @ R
    Y = tx40.regressor(q, qd, qdd)
    np.testing.assert_allclose(Y @ tx40.theta_true, ref, rtol=0, atol=1e-10)
    # one column at a time: the unit parameter's torque through R^T
    for name, drive in (("Iam6", qdd_m[:, 5] / n6 ** 2), ("fvm6", qd_m[:, 5] / n6 ** 2),
                        ("fsm6", np.sign(qd_m[:, 5]) / n6)):
        one = np.zeros_like(qd)
        one[:, 5] = drive
        np.testing.assert_allclose(Y @ column(tx40, name), one @ R, rtol=0, atol=1e-12)


def test_figaroh_form_gives_the_same_torques(tx40):
    """FIGAROH's TX40 model with its configuration values (Ia, fv, fs, offset, Iam6, fvm6, fsm6) gives the
    same joint torques as ours with its Ia5, Ia6, fv5, fv6 less Iam6, fvm6: the parameters are joint side."""
    model = pin.buildModelFromUrdf(str(URDF))
    data = model.createData()
    q, qd, qdd = states(tx40)
    fig = np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(len(q))])
    fig += FIGAROH["Ia"] * qdd + FIGAROH["fv"] * qd + FIGAROH["fs"] * np.sign(qd) + FIGAROH["offset"]
    s = np.sign(qd[:, 4] + qd[:, 5])
    fig[:, 4] += IAM6 * qdd[:, 5] + FVM6 * qd[:, 5] + FSM6 * s
    fig[:, 5] += IAM6 * qdd[:, 4] + FVM6 * qd[:, 4] + FSM6 * s
    np.testing.assert_allclose(tx40.inverse_dynamics(q, qd, qdd), fig, rtol=0, atol=1e-10)


# -- energy, momentum and power ----------------------------------------------------------------------
def test_energy_and_momentum_by_finite_differences(tx40):
    """Along a smooth motion (central differences, h = 1e-5 s), for the whole theta and for each coupled-motor
    column alone: d/dt(phi_H theta) = qd^T Y theta - phi_f theta (the power balance) and d/dt(Ya theta) +
    Yb theta = Y theta; and the coupled motor's kinetic energy is Iam6 (qd5 + qd6)^2 / 2."""
    h = 1e-5
    for t in (0.35, 1.3, 2.9):
        q, qd, qdd = motion(t)
        qp, qdp, _ = motion(t + h)
        qm, qdm, _ = motion(t - h)
        Y = tx40.regressor(q, qd, qdd)
        for theta in (tx40.theta_true, column(tx40, "Iam6"), column(tx40, "fvm6"), column(tx40, "fsm6")):
            dH = (tx40.energy_regressor(qp, qdp) @ theta - tx40.energy_regressor(qm, qdm) @ theta) / (2 * h)
            power = qd @ (Y @ theta) - tx40.friction_power_regressor(qd) @ theta
            np.testing.assert_allclose(dH, power, rtol=0, atol=1e-6 * max(1.0, abs(power)))
            dp = (tx40.momentum_regressor(qp, qdp) @ theta - tx40.momentum_regressor(qm, qdm) @ theta) / (2 * h)
            np.testing.assert_allclose(dp + tx40.remainder_regressor(q, qd) @ theta, Y @ theta, rtol=0, atol=1e-6)
        w = qd[4] + qd[5]
        assert tx40.energy_regressor(q, qd) @ column(tx40, "Iam6") == pytest.approx(0.5 * w * w, rel=1e-14)
        assert tx40.friction_power_regressor(qd) @ (column(tx40, "fvm6") + column(tx40, "fsm6")) == pytest.approx(
            w * w + abs(w), rel=1e-14)
    q, qd, _ = states(tx40, 5)
    np.testing.assert_allclose(np.einsum("Nij,Nj->Ni", tx40.mass_matrix(q), qd),
                               tx40.momentum_regressor(q, qd) @ tx40.theta_true, rtol=0, atol=1e-12)


# -- dynamics ----------------------------------------------------------------------------------------
def test_mass_matrix_and_forward_dynamics(tx40, plain):
    """M = CRBA (with armature) + Iam6 r r^T, r = e5 + e6: symmetric positive definite; forward dynamics
    (batch, the simulator's one-state path and the ZOH stepper) inverts the inverse dynamics."""
    q, qd, qdd = states(tx40)
    M = tx40.mass_matrix(q)
    r = np.array([0, 0, 0, 0, 1.0, 1.0])
    np.testing.assert_allclose(M, plain.mass_matrix(q) + IAM6 * np.outer(r, r), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(M, np.swapaxes(M, 1, 2))
    assert np.linalg.eigvalsh(M).min() > 0
    tau = tx40.inverse_dynamics(q, qd, qdd)
    np.testing.assert_allclose(np.einsum("Nij,Nj->Ni", M, qdd) + tx40.bias_torque(q, qd), tau, rtol=0, atol=1e-10)
    np.testing.assert_allclose(tx40.forward_dynamics(q, qd, tau), qdd, rtol=0, atol=1e-9)
    for k in range(3):
        one = tx40.fast_acceleration(q[k].tolist(), qd[k].tolist(), tau[k].tolist(), tx40.theta_true.tolist(), 0.0)
        np.testing.assert_allclose(one, qdd[k], rtol=0, atol=1e-9)
    # the stepper over one short hold against the Taylor step (q, qd) + (qd, qdd) dt + (qdd, .) dt^2 / 2
    width, dt = 0.05, 1e-4
    acc = tx40.forward_dynamics(q[0], qd[0], tau[0], coulomb_width=width)
    q1, qd1, _ = tx40.zoh_stepper()(q[0], qd[0], tau[0], dt, 2, width, None)
    np.testing.assert_allclose(q1, q[0] + qd[0] * dt + 0.5 * acc * dt * dt, rtol=0, atol=1e-9)
    np.testing.assert_allclose(qd1, qd[0] + acc * dt, rtol=0, atol=1e-5)


def test_constraints_and_base_parameters(tx40, plain):
    """Iam6, fvm6, fsm6 >= 0 are constraint rows; they are identifiable: 3 more base parameters than without."""
    labels = tx40.physical_constraints(pseudo_inertia=False).linear.labels
    assert {"Iam6 >= 0", "fvm6 >= 0", "fsm6 >= 0"} <= set(labels)
    with_motor, without = base_parameters(tx40, n_states=60), base_parameters(plain, n_states=60)
    assert with_motor.rank == without.rank + 3
    assert {"Iam6", "fvm6", "fsm6"} <= set(with_motor.symbols)


@pytest.mark.parametrize("kwargs, match", [
    ({"viscous": [0.1] * 5}, r"viscous must be one number or a list of 6 \(one per joint\), got 5 numbers"),
    ({"coulomb": [0.1, -1, 0, 0, 0, 0]}, r"coulomb must be finite and >= 0; entry 2 of 6 is -1"),
    ({"with_armature": True, "armature": np.inf}, r"armature must be finite"),
    ({"coupled_motors": [{**WRIST, "joints": [6, 7]}]}, r"joints \[6, 7\] must be joint numbers in 1\.\.6"),
    ({"coupled_motors": [WRIST, WRIST]}, r"names motor\(s\) \[6\] twice"),
    ({"coupled_motors": [{**WRIST, "armature": -1.0}]}, r"armature must be a finite number >= 0"),
])
def test_python_api_refuses_bad_values(kwargs, match):
    with pytest.raises(InputError, match=match):
        UrdfRobot(URDF, **kwargs)


# -- the study file ----------------------------------------------------------------------------------
STUDY = """
regressions = ["inverse_dynamic"]
[study]
name = "s"
title = "t"
[robot]
model = "urdf"
[robot.options]
source = "{urdf}"
parameters = "standard"
{options}
[experiment]
source = "simulate"
[[estimators]]
method = "wls"
regressions = ["inverse_dynamic"]
"""


def _study(tmp_path, options: str) -> Path:
    path = tmp_path / "study.toml"
    path.write_text(STUDY.format(urdf=URDF.as_posix(), options=options))
    return path


def test_study_file_takes_per_joint_lists_and_a_coupled_motor(tmp_path):
    from boundid.studies.registry import make_robot

    text = ("viscous = [1.2, 1.1, 0.9, 0.5, 0.6, 0.03]\ncoulomb = 2\narmature = [0.36, 0.36, 0.1, 0.03, 0.037, 0]\n"
            "offset = [0.39, 1.37, 0.33, -0.1, -0.03, 0.13]\n"
            "coupled_motors = [{motor = 6, joints = [5, 6], ratios = [32, 32], armature = 9.64e-3, viscous = 0.616, "
            "coulomb = 1.95}]")
    cfg = load_study(_study(tmp_path, text))
    assert cfg.robot_options["viscous"] == (1.2, 1.1, 0.9, 0.5, 0.6, 0.03)
    robot = make_robot(cfg.robot, cfg.robot_options)
    th = robot.theta_true
    np.testing.assert_array_equal(th[robot._slices["fv"]], [1.2, 1.1, 0.9, 0.5, 0.6, 0.03])
    np.testing.assert_array_equal(th[robot._slices["fc"]], [2.0] * 6)
    np.testing.assert_array_equal(th[robot._slices["Ia"]], [0.36, 0.36, 0.1, 0.03, 0.037, 0])
    np.testing.assert_array_equal(th[robot._slices["off"]], [0.39, 1.37, 0.33, -0.1, -0.03, 0.13])
    assert robot.param_names[-3:] == ("Iam6", "fvm6", "fsm6")
    np.testing.assert_array_equal(th[-3:], [9.64e-3, 0.616, 1.95])
    # a list of zeros is given values: the armature parameters are added, at 0
    zeros = make_robot(cfg.robot, {"source": str(URDF), "parameters": "standard", "armature": (0.0,) * 6})
    assert "Ia6" in zeros.param_names and "Ia6" not in make_robot(cfg.robot, {"source": str(URDF),
                                                                              "parameters": "standard"}).param_names


@pytest.mark.parametrize("options, match", [
    ("viscous = [1.0, 2.0]", r"viscous must be one number or a list of 6 \(one per joint\), got 2 numbers"),
    ("coulomb = [1, 1, 1, -1, 1, 1]", r"coulomb must be finite and >= 0; entry 4 of 6 is -1"),
    ("armature = [0.1, 0.1, 0.1, 0.1, 0.1, nan]", r"robot\.options\.armature: must be finite"),
    ('offset = "big"', r"robot\.options\.offset: must be a number or list of numbers"),
    ("offset = [1, 2, 3]", r"offset must be one number or a list of 6 \(one per joint\), got 3 numbers"),
    ("coupled_motors = [6, 5]", r"robot\.options\.coupled_motors: must be a list of tables"),
    ("coupled_motors = [{motor = 6, joints = [5, 6]}]", r"coupled_motors entry 1: missing key 'ratios'"),
    ("coupled_motors = [{motor = 6, joints = [5, 6], ratio = [32, 32]}]", r"entry 1: unknown key 'ratio'"),
    ("coupled_motors = [{motor = 6, joints = [5, 6], ratios = [32]}]", r"ratios must be 2 finite nonzero numbers"),
    ("coupled_motors = [{motor = 6, joints = [4, 5], ratios = [1, 32]}]", r"must include the motor's own joint 6"),
    ("coupled_motors = [{motor = 6, joints = [6], ratios = [32]}]", r"turns with its own joint only"),
    ("coupled_motors = [{motor = 6, joints = [5, 6], ratios = [32, 32], coulomb = -2}]",
     r"coupled motor 6: coulomb must be a finite number >= 0"),
])
def test_study_file_refuses_wrong_values_in_one_line(tmp_path, options, match):
    with pytest.raises(StudyError, match=match) as err:
        load_study(_study(tmp_path, options))
    assert "\n" not in str(err.value)
