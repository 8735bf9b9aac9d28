"""The built-in direct-drive arm (DirectDriveArm) written as a 2-link URDF, shared by the tests that
compare a URDF robot with it: joints about x, links hanging along -z at q = 0, centres of mass on the
link axes, the arm's viscous and Coulomb friction in <dynamics>. With gravity (0, 0, -g) its
dynamics are the arm's (tests/test_urdf.py checks torques, mass matrix, energy and base parameters)."""

from __future__ import annotations

from pathlib import Path

from boundid.models.direct_drive import PHYSICAL


def planar_arm_urdf(folder: Path, P: dict = PHYSICAL, name: str = "planar_arm.urdf") -> Path:
    """Write the URDF into ``folder`` and return its path."""
    def link(lname, m, lc, I):
        return (f'<link name="{lname}"><inertial><origin xyz="0 0 {-lc}"/><mass value="{m}"/>'
                f'<inertia ixx="{I}" ixy="0" ixz="0" iyy="{I}" iyz="0" izz="{I / 10}"/></inertial></link>')

    def joint(jname, parent, child, z, b, fc):
        return (f'<joint name="{jname}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="0 0 {-z}"/><axis xyz="1 0 0"/>'
                f'<limit lower="-3.14" upper="3.14" velocity="6" effort="200"/>'
                f'<dynamics damping="{b}" friction="{fc}"/></joint>')
    body = (link("l1", P["m1"], P["lc1"], P["I1"]) + link("l2", P["m2"], P["lc2"], P["I2"])
            + joint("j1", "base", "l1", 0.0, P["b1"], P["fc1"]) + joint("j2", "l1", "l2", P["l1"], P["b2"], P["fc2"]))
    path = Path(folder) / name
    path.write_text(f'<robot name="r"><link name="base"/>{body}</robot>')
    return path
