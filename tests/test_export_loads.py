"""Exports that load: the URDF copy and the MJCF fragment of an identified UR5 (three positioning
joints, friction and armature, base parameters) read by pinocchio and by MuJoCo.

Independent references: pinocchio's URDF parser (every body's mass, principal moments and their
triangle inequality; the bodies read back); MuJoCo's URDF compiler without ``balanceinertia`` (it
refuses A + B < C: checked on a copy with the shoulder's Izz of the issue) and its MJCF include and
MjSpec, whose joints must carry the exported armature, damping and frictionloss; the constrained
least squares of the data the covariance comes from (QR of the rows) for the projection of an
inconsistent estimate (Cholesky of the covariance); the planar arm's study page for the export of
an inconsistent WLS centre.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pinocchio as pin
import pytest
import yaml

from boundid.errors import InputError
from boundid.models.base_parameters import BaseParameterModel
from boundid.models.urdf import UrdfRobot
from boundid.models.urdf_export import LINK_MARGIN, export_constraints, link_problems
from boundid.report.study_page import write_study_report
from boundid.sets.physical import constrained_fit
from boundid.studies.physical_stage import most_violated, physical_stage
from mujoco_recording import UR5_JOINTS, mujoco_urdf, true_theta
from test_urdf_study import planar_study
from tiny_study import run_study_text

#: the joints' true armature [kg m^2] against the 0.1 the robot states, viscous [N m s/rad] and Coulomb [N m] friction
ARMATURE, VISCOUS, COULOMB = np.array([0.25, 0.2, 0.15]), np.array([0.8, 0.6, 0.4]), np.array([1.2, 0.9, 0.7])


@pytest.fixture(scope="module")
def ur5():
    """The UR5 as a study identifies it: URDF inertias, armature 0.1 stated, base parameters (~1 s)."""
    return BaseParameterModel(UrdfRobot("ur5", UR5_JOINTS, viscous=0.5, coulomb=1.0, with_armature=True,
                                        armature=0.1))


def identified(model) -> np.ndarray:
    """Base parameters of the URDF's links with the true armature and friction (a perfect identification)."""
    robot = model.robot
    theta = robot.theta_true.copy()
    for key, values in (("Ia", ARMATURE), ("fv", VISCOUS), ("fc", COULOMB)):
        theta[[robot.param_names.index(f"{key}{j}") for j in (1, 2, 3)]] = values
    return model.base.base(theta)


def exported_standard(paths) -> np.ndarray:
    """The standard vector of the exported YAML table."""
    doc = yaml.safe_load(paths[2].read_text())
    return np.array([row["value"] for row in doc["standard"]])


def joint_values(mj: mujoco.MjModel) -> np.ndarray:
    """(3, n): armature, damping and frictionloss of MuJoCo's dofs."""
    return np.array([mj.dof_armature, mj.dof_damping, mj.dof_frictionloss])


def assert_loads(robot: UrdfRobot, paths, x: np.ndarray) -> None:
    """The exported URDF and MJCF fragment of the standard vector x, read by pinocchio and MuJoCo."""
    urdf, fragment = paths[0], paths[1]
    n = robot.n_joints
    # pinocchio, the whole arm (wrist joints too): every body a rigid body
    model = pin.buildModelFromUrdf(str(urdf))
    for inertia in model.inertias[1:]:
        a, b, c = np.linalg.eigvalsh(inertia.inertia)
        assert inertia.mass > 0 and a > 0 and a + b > c
    np.testing.assert_allclose(UrdfRobot(urdf, joints=robot.joint_names).theta_true[:10 * n], x[:10 * n], atol=1e-12)
    # MuJoCo's URDF compiler, without balanceinertia: the same bodies, damping and friction from <dynamics>
    text = mujoco_urdf(str(urdf), robot.joint_names)
    assert ET.fromstring(text).find("mujoco/compiler").get("balanceinertia") is None
    mj = mujoco.MjModel.from_xml_string(text)
    np.testing.assert_allclose(true_theta(mj, robot)[:10 * n], x[:10 * n], atol=1e-10)
    index = [[robot.param_names.index(f"{key}{j}") for j in range(1, n + 1)] for key in ("Ia", "fv", "fc")]
    np.testing.assert_array_equal(joint_values(mj)[1:], x[index[1:]])
    # the fragment as its header says: MjSpec, and an MJCF that includes it
    classes = mujoco.MjSpec.from_file(str(fragment))
    spec = mujoco.MjSpec.from_string(text)
    for joint in spec.joints:
        c = classes.find_default(joint.name)
        joint.armature, joint.damping, joint.frictionloss = c.joint.armature, c.joint.damping, c.joint.frictionloss
    np.testing.assert_array_equal(joint_values(spec.compile()), x[index])
    root = ET.fromstring(mujoco.MjSpec.from_string(text).to_xml())
    root.insert(0, ET.Element("include", file=fragment.name))
    for joint in root.iter("joint"):
        joint.set("class", joint.get("name"))
        for own in ("damping", "frictionloss"):
            joint.attrib.pop(own, None)
    main = fragment.parent / "with_fragment.xml"
    main.write_text(ET.tostring(root, encoding="unicode"))
    np.testing.assert_array_equal(joint_values(mujoco.MjModel.from_xml_path(str(main))), x[index])
    main.unlink()


def test_an_identified_ur5_exports_a_urdf_that_pinocchio_and_mujoco_load(ur5, tmp_path):
    """The issue's case: the armature above the stated 0.1 sits in Izz1R = Izz1 + ... + Ia1 and Iyy2R. Mapped
    with the dependent parameters at their stated values it lands in the links (the shoulder's Izz > Ixx + Iyy,
    which MuJoCo refuses). Exported: the links keep the URDF's values, the armature is the true one, in the MJCF
    fragment, and both files load."""
    robot, beta = ur5.robot, identified(ur5)
    folded = link_problems(robot, ur5.standard(beta))
    assert any("shoulder_link" in p and "triangle" in p for p in folded), folded
    paths = ur5.export_identified(beta, tmp_path, estimate="the truth")
    assert [p.name for p in paths] == ["ur5_identified.urdf", "ur5_mujoco.xml", "ur5_identified.yaml",
                                       "ur5_identified.csv"]
    x = exported_standard(paths)
    np.testing.assert_allclose(ur5.base.base(x), beta, rtol=1e-12, atol=1e-14)
    scale = robot.physical_constraints().scale  # each body's m, m l, m l^2
    assert np.all(np.abs(x[:30] - robot.theta_true[:30]) <= 1e-4 * scale[:30])
    np.testing.assert_allclose(x[[robot.param_names.index(f"Ia{j}") for j in (1, 2, 3)]], ARMATURE, rtol=1e-3)
    assert "the truth" in paths[0].read_text() and "balanceinertia" in paths[0].read_text()
    assert_loads(robot, paths, x)
    # the check the test relies on: the same compiler options refuse the shoulder (0.0103, 0.0103, 0.195)
    bad = ET.parse(paths[0])
    bad.getroot().find("link[@name='shoulder_link']/inertial/inertia").set("izz", "0.195")
    bad.write(tmp_path / "bad.urdf")
    with pytest.raises(ValueError, match="A \\+ B >= C"):
        mujoco.MjModel.from_xml_string(mujoco_urdf(str(tmp_path / "bad.urdf"), UR5_JOINTS))


def test_an_inconsistent_estimate_goes_to_the_tables_only(ur5, tmp_path):
    """A negative Coulomb coefficient and a forearm whose base parameters no rigid body has (Iyy3 below
    Ixx3R = Ixx3 - Izz3: its pseudo-inertia cannot be >= 0). Without a covariance nothing is written and the
    message names the links; with one, the URDF holds the projection, which equals the constrained least
    squares of the rows the covariance comes from, and the estimate itself is in the unconstrained tables."""
    robot, names = ur5.robot, ur5.param_names
    beta = identified(ur5)
    beta[names.index("fc2")] = -0.3
    beta[names.index("Iyy3")] = beta[names.index("Ixx3R")] - 0.2
    with pytest.raises(InputError, match="not written as a URDF.*forearm_link"):
        ur5.export_identified(beta, tmp_path)
    assert not any(tmp_path.iterdir())
    rng = np.random.default_rng(3)
    lim = robot.limits
    q = rng.uniform(np.maximum(lim.lower, -np.pi), np.minimum(lim.upper, np.pi), (300, 3))
    qd, qdd = rng.uniform(-1, 1, (300, 3)) * lim.velocity, rng.uniform(-1, 1, (300, 3)) * lim.acceleration
    W = ur5.regressor(q, qd, qdd).reshape(-1, ur5.p)
    paths = ur5.export_identified(beta, tmp_path, estimate="a bad centre", cov=np.linalg.inv(W.T @ W))
    assert [p.name for p in paths[4:]] == ["ur5_unconstrained.yaml", "ur5_unconstrained.csv"]
    raw = yaml.safe_load(paths[4].read_text())
    assert "standard" not in raw
    np.testing.assert_allclose([row["value"] for row in raw["base"]], beta, rtol=1e-14, atol=1e-15)
    assert "projection of a bad centre" in yaml.safe_load(paths[2].read_text())["estimate"]
    x = exported_standard(paths)
    reference = constrained_fit(W, W @ beta, export_constraints(robot, 2 * LINK_MARGIN).lifted(ur5.base.K, names))[0]
    np.testing.assert_allclose(ur5.base.base(x), reference, atol=1e-6 * np.abs(reference).max())
    assert x[robot.param_names.index("fc2")] >= 0
    assert_loads(robot, paths, x)


def test_the_most_violated_constraint_is_named_for_base_parameters(ur5):
    """Lifted constraints (base parameters) name the constraint no standard vector can satisfy, with its
    violation in parameter units (the column was empty for them)."""
    cons, names = ur5.physical_constraints(), ur5.param_names
    beta = identified(ur5)
    margin, worst = most_violated(cons, beta)
    assert margin >= 0 and worst == ""
    friction = beta.copy()
    friction[names.index("fc2")] = -0.3
    margin, worst = most_violated(cons, friction)
    assert margin < 0 and worst == "fc2 >= 0 (Coulomb friction dissipates) by 0.3"
    forearm = beta.copy()
    forearm[names.index("Iyy3")] = beta[names.index("Ixx3R")] - 0.2
    margin, worst = most_violated(cons, forearm)
    assert margin < 0 and worst.startswith("J3 >= 0 (pseudo-inertia of body 3 (forearm_link)) by ")


def test_the_study_page_exports_the_projection_of_an_inconsistent_wls(tmp_path):
    """The planar arm's study with its WLS centre given a negative Coulomb coefficient: the physical stage names
    it, and the page exports the projection as the URDF and the centre to the tables only, saying so."""
    r = run_study_text(tmp_path, "planar", planar_study(tmp_path))[1]
    key = ("WLS", "inverse_dynamic")
    center = r.estimates[key].center.copy()
    center[r.model.param_names.index("fc1")] = -0.5
    r.estimates[key] = dataclasses.replace(r.estimates[key], center=center)
    r.exact.physical = physical_stage(r.exact.polytope, r.model.physical_constraints(), r.model.param_names,
                                      {"WLS": r.estimates[key]})
    assert r.exact.physical.estimates.loc["WLS", "worst"] == "fc1 >= 0 (Coulomb friction dissipates) by 0.5"
    page = write_study_report(r, tmp_path / "page").read_text()
    export = tmp_path / "page" / "export"
    assert sorted(p.name for p in export.iterdir()) == sorted(
        f"planar_arm_{s}" for s in ("identified.urdf", "mujoco.xml", "identified.yaml", "identified.csv",
                                    "unconstrained.yaml", "unconstrained.csv"))
    assert "is not physically consistent (most violated: fc1 &gt;= 0" in page and "tables only" in page
    back = UrdfRobot(export / "planar_arm_identified.urdf")
    assert not link_problems(back, back.theta_true) and back.theta_true[back.param_names.index("fc1")] >= 0
