"""URDF <inertial> tags read and written: the parameters of a link as the file gives them, and
identified parameters written out into a copy of the URDF and as CSV or YAML tables (``robot`` is
a :class:`boundid.models.urdf.UrdfRobot`).

URDF: pinocchio merges into body j every link rigidly attached to joint j's child link (fixed
joints, and the joints locked by ``joints=``). The identified body j is written into the child
link's <inertial> tag, minus the part of the merged links as the source file gives it:

    pi_link,new = pi_body,identified - (pi_body,URDF - pi_link,URDF)

(dynamic parameters about the link frame, linear in the bodies), so the other links keep their
values and reloading the file gives back pi_body,identified. The tag holds the mass, the centre of
mass c = (m c) / m as <origin xyz>, and the inertia about c in the link's axes,
I_C = I - m S(c)^T S(c) (rpy = 0). Friction goes to each joint's <dynamics damping friction>;
armature and offsets have no URDF tag and go only to the tables. A standard vector for base
parameters comes from :meth:`BaseParameters.standard` (the URDF's values for the parameters the
data cannot separate).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pinocchio as pin
import yaml

from boundid._validation import as_vector
from boundid.errors import InputError
from boundid.models.base_parameters import BaseParameters


def link_inertial_parameters(inertial: ET.Element | None, link: str) -> np.ndarray:
    """Dynamic parameters (10,) about the link frame of a URDF <inertial> element (zeros if absent or massless).

    Every number is checked here: urdfdom only prints a console message for a malformed one and
    loads the link with a zero inertia.
    """
    if inertial is None:
        return np.zeros(10)

    def numbers(tag: str, attr: str, default: str, size: int) -> np.ndarray:
        e = inertial.find(tag)
        text = default if e is None else e.get(attr, default)
        try:
            v = np.array(text.split(), float)
        except ValueError:
            v = np.array([])
        if v.shape != (size,) or not np.all(np.isfinite(v)):
            raise InputError(f"link {link!r}: <{tag} {attr}={text!r}> must be {size} finite number(s); fix the URDF.")
        return v

    xyz, rpy = numbers("origin", "xyz", "0 0 0", 3), numbers("origin", "rpy", "0 0 0", 3)
    m = numbers("mass", "value", "0", 1)[0]
    g = {k: numbers("inertia", k, "0", 1)[0] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    if m == 0.0:
        return np.zeros(10)
    I_c = np.array([[g["ixx"], g["ixy"], g["ixz"]], [g["ixy"], g["iyy"], g["iyz"]], [g["ixz"], g["iyz"], g["izz"]]])
    body = pin.SE3(pin.rpy.rpyToMatrix(rpy), xyz).act(pin.Inertia(m, np.zeros(3), I_c))
    return body.toDynamicParameters()


def _set_inertial(link: ET.Element, pi: np.ndarray, label: str) -> None:
    """Replace the link's <inertial> by mass, COM and inertia about the COM from parameters pi (10,)."""
    if not pi[0] > 0:
        raise InputError(f"{label}: the identified mass minus the attached links' URDF mass is {pi[0]:.6g} kg; a URDF "
                         "inertial needs a positive mass. Check the identified parameters (or the attached links).")
    body = pin.Inertia.FromDynamicParameters(pi)
    old = link.find("inertial")
    if old is not None:
        link.remove(old)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz=" ".join(repr(float(x)) for x in body.lever), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=repr(float(body.mass)))
    I = {f"i{a}{b}": repr(float(body.inertia[i, k])) for a, b, i, k in
         (("x", "x", 0, 0), ("x", "y", 0, 1), ("x", "z", 0, 2), ("y", "y", 1, 1), ("y", "z", 1, 2), ("z", "z", 2, 2))}
    ET.SubElement(inertial, "inertia", **I)


def write_urdf(robot, theta, path: str | Path) -> Path:
    """Write a copy of ``robot``'s URDF with the inertias and friction of ``theta`` (p,); returns the path."""
    theta = as_vector(theta, "theta", robot.p)
    out = Path(path)
    if out.resolve() == robot.urdf_path.resolve():
        raise InputError(f"refusing to overwrite the source URDF {out}; write the identified copy elsewhere.")
    tree = ET.parse(robot.urdf_path)
    root = tree.getroot()
    links = {e.get("name"): e for e in root.findall("link")}
    joints = {e.get("name"): e for e in root.findall("joint")}
    n = robot.n_joints
    for j in range(n):
        link = links[robot.link_names[j]]
        own = link_inertial_parameters(link.find("inertial"), robot.link_names[j])
        attached = robot.theta_true[10 * j:10 * j + 10] - own
        _set_inertial(link, theta[10 * j:10 * j + 10] - attached, f"link {robot.link_names[j]}")
        joint = joints[robot.joint_names[j]]
        dyn = joint.find("dynamics")
        if dyn is None:
            dyn = ET.SubElement(joint, "dynamics")
        dyn.set("damping", repr(float(theta[robot.param_names.index(f"fv{j + 1}")])))
        dyn.set("friction", repr(float(theta[robot.param_names.index(f"fc{j + 1}")])))
    ET.indent(tree)
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out


def parameter_table(robot, theta, base: BaseParameters | None = None) -> pd.DataFrame:
    """Rows (set, name, unit, value): the standard vector ``theta`` (p,), then K theta if ``base`` is given."""
    theta = as_vector(theta, "theta", robot.p)
    rows = [("standard", nm, u, float(v)) for nm, u, v in zip(robot.param_names, robot.param_units, theta, strict=True)]
    if base is not None:
        rows += [("base", nm, u, float(v)) for nm, u, v in zip(base.names, base.units, base.base(theta), strict=True)]
    return pd.DataFrame(rows, columns=["set", "name", "unit", "value"])


def write_parameters(robot, theta, path: str | Path, base: BaseParameters | None = None) -> Path:
    """Write :func:`parameter_table` to ``path``: CSV (.csv) or YAML (.yaml/.yml, with robot, URDF, joints)."""
    out = Path(path)
    table = parameter_table(robot, theta, base)
    if out.suffix == ".csv":
        table.to_csv(out, index=False, float_format="%.17g")
    elif out.suffix in (".yaml", ".yml"):
        doc = {"robot": robot.name, "urdf": str(robot.urdf_path), "joints": list(robot.joint_names)}
        for kind, group in table.groupby("set", sort=False):
            doc[kind] = [{"name": r.name, "unit": r.unit, "value": r.value} for r in group.itertuples()]
        out.write_text(yaml.safe_dump(doc, sort_keys=False))
    else:
        raise InputError(f"unknown table format {out.suffix!r} for {out}; use .csv, .yaml or .yml.")
    return out
