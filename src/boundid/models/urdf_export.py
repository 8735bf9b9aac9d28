"""URDF <inertial> tags read and written: the parameters of a link as the file gives them, and
identified parameters exported as a copy of the URDF that simulators load, an MJCF fragment with
the joints' armature and friction, and CSV or YAML tables (``robot`` is a
:class:`boundid.models.urdf.UrdfRobot`).

URDF: pinocchio merges into body j every link rigidly attached to joint j's child link (fixed
joints, and the joints locked by ``joints=``). The identified body j is written into the child
link's <inertial> tag, minus the part of the merged links as the source file gives it:

    pi_link,new = pi_body,identified - (pi_body,URDF - pi_link,URDF)

(dynamic parameters about the link frame, linear in the bodies), so the other links keep their
values and reloading the file gives back pi_body,identified. The tag holds the mass, the centre of
mass c = (m c) / m as <origin xyz>, and the inertia about c in the link's axes,
I_C = I - m S(c)^T S(c) (rpy = 0). Friction goes to each joint's <dynamics damping friction>
(MuJoCo reads them as damping and frictionloss). Armature is a joint property (pinocchio's
``model.armature``, MuJoCo's joint ``armature``), never a link inertia: it goes to the MJCF
fragment ``<robot>_mujoco.xml`` (one default class per joint, named after it) and the tables;
offsets and coupled motors' parameters only to the tables.

What is written is loadable. A link is written only if it is a rigid body: mass > 0 and principal
moments of I_C with A + B > C for every ordering (hence > 0), what pinocchio's and MuJoCo's
loaders need (MuJoCo refuses A + B < C unless told to ``balanceinertia``). :func:`loadable_standard`
chooses the standard vector:

* base parameters beta = K theta fix only combinations of the standard ones. Of the standard
  vectors x with K x = beta, the one written is the nearest to the URDF's values (the robot's
  ``theta_true``) in units of each body's mass and size (``physical_constraints().scale``) whose
  links are rigid bodies with a margin: J(link) >= LINK_MARGIN J(URDF body) for the pseudo-inertia
  J (:func:`export_constraints`), friction and armature >= 0. Armature deviations weigh
  ARMATURE_WEIGHT of link deviations (per unit of their scales), so a combination such as
  Izz1R = Izz1 + ... + Ia1 keeps the links at the URDF's values and puts what is left in the
  armature: CAD inertias are of the links, a URDF carries no rotor inertia.
* when no such x exists (the estimate is not physically consistent, or not for the links), the
  estimate is not written as a URDF. Given its covariance, its projection onto the physical set is
  exported instead: the least squares in the estimate's own metric (theta - hat)^T cov^-1
  (theta - hat) under the constraints with margin 2 LINK_MARGIN
  (:func:`boundid.sets.physical.constrained_fit`, an LMI-constrained least squares; for a least
  squares estimate it is the constrained least squares of its own rows, whose residual sum of
  squares exceeds the estimate's by exactly that form, up to the scale of cov), and the estimate
  itself goes to the tables only. Its standard vector is again the nearest to the URDF's, or, when
  Clarabel cannot place that one inside the thin set left by the projection's active links (seen
  on the Staubli TX40), the projection's own standard vector (the lifted solution).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import cvxpy as cp
import numpy as np
import pandas as pd
import pinocchio as pin
import yaml

from boundid._validation import as_matrix, as_vector
from boundid.errors import InputError, SolverError
from boundid.models.base_parameters import BaseParameters
from boundid.sets.conic import InfeasibleProblem, lmi_expressions
from boundid.sets.conic import solve as solve_conic
from boundid.sets.constraints import MatrixInequality, PhysicalConstraints, constraints, pseudo_inertia
from boundid.sets.physical import constrained_fit

#: margin of an exported link's pseudo-inertia, J(link) >= LINK_MARGIN J(body in the URDF): every
#: written link is strictly a rigid body, so rounding (MuJoCo's eigen-decomposition of I_C) cannot
#: turn A + B = C into A + B < C
LINK_MARGIN = 1e-4
#: weight of an armature's deviation from its stated value against a link parameter's, per unit of
#: their scales (module docstring)
ARMATURE_WEIGHT = 1e-3
#: parameter families written as joint armature (rotor inertias)
_ARMATURE_KEYS = ("Ia", "Iam")


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


def attached_parameters(robot) -> np.ndarray:
    """(n, 10): per body j, the dynamic parameters about joint j's frame of the links merged into it
    besides its own child link, at the URDF's values (body j of ``theta_true`` minus the link's <inertial>)."""
    links = {e.get("name"): e for e in ET.parse(robot.urdf_path).getroot().findall("link")}
    return np.array([robot.theta_true[10 * j:10 * j + 10] - link_inertial_parameters(links[name].find("inertial"), name)
                     for j, name in enumerate(robot.link_names)]).reshape(robot.n_joints, 10)


def link_problems(robot, theta) -> list[str]:
    """Why links of ``theta`` (p,) are not rigid bodies once the merged links are removed (module
    docstring): one sentence per link at fault, [] when every link can be written. A link needs
    m > 0 and principal moments a <= b <= c of I_C [kg m^2] with a + b > c (which gives a > 0)."""
    theta = as_vector(theta, "theta", robot.p)
    attached = attached_parameters(robot)
    out = []
    for j, name in enumerate(robot.link_names):
        pi = theta[10 * j:10 * j + 10] - attached[j]
        if not pi[0] > 0:
            out.append(f"link {name!r}: mass {pi[0]:.6g} kg once the attached links' URDF mass is removed, but a URDF "
                       "inertial needs a positive mass")
            continue
        a, b, c = np.linalg.eigvalsh(pin.Inertia.FromDynamicParameters(pi).inertia)
        if not a + b > c:
            out.append(f"link {name!r}: principal moments {a:.4g}, {b:.4g}, {c:.4g} kg m^2 break the triangle "
                       f"inequality ({a:.4g} + {b:.4g} <= {c:.4g}), which MuJoCo refuses")
    return out


def export_constraints(robot, margin: float = LINK_MARGIN) -> PhysicalConstraints:
    """The robot's physical constraints on its standard parameters (p,), each body's pseudo-inertia
    LMI replaced by its link's with a margin: J(body - attached) >= margin J(URDF body), J the 4 x 4
    pseudo-inertia (:func:`boundid.sets.constraints.pseudo_inertia`, linear in the 10 parameters).
    The URDF's attached links are rigid bodies, so these imply the robot's own J(body) >= 0."""
    own = robot.physical_constraints()
    attached = attached_parameters(robot)
    lmis = []
    for j, name in enumerate(robot.link_names):
        s0 = 10 * j
        J = pseudo_inertia(robot.p, s0, f"J({name}) >= {margin:g} J(URDF body {j + 1})",
                           f"pseudo-inertia of link {name} (body {j + 1} minus the links merged into it, at their "
                           "URDF values): a rigid body, with a margin")
        shift = np.zeros(robot.p)
        shift[s0:s0 + 10] = attached[j] + margin * robot.theta_true[s0:s0 + 10]
        lmis.append(MatrixInequality(J.matrix(-shift), J.F, J.label, J.reason))
    return constraints(own.names, own.linear, lmis=lmis, scale=own.scale)


def _nearest_standard(robot, cons: PhysicalConstraints, base: BaseParameters, beta: np.ndarray) -> np.ndarray | None:
    """The x (p,) satisfying ``cons`` with K x = beta (r,) nearest ``theta_true``: min sum_i (g_i (x_i -
    ref_i) / s_i)^2 with s = cons.scale, g = ARMATURE_WEIGHT for armature, else 1 (module docstring),
    by Clarabel in the coordinates w = x / s; then K x = beta to rounding (the kept parameters take
    the solver's residual). None when no such x exists."""
    p, s = robot.p, cons.scale
    g = np.array([ARMATURE_WEIGHT if nm.rstrip("0123456789") in _ARMATURE_KEYS else 1.0 for nm in robot.param_names])
    w = cp.Variable(p)
    Ks = base.K * s[None, :]
    rn = np.abs(Ks).max(axis=1)
    parts = [(Ks / rn[:, None]) @ w == beta / rn]
    cw = cons.in_coordinates(np.zeros(p), np.diag(s))
    if cw.linear.m:
        nrm = np.linalg.norm(cw.linear.A, axis=1)
        parts.append((cw.linear.A / nrm[:, None]) @ w <= cw.linear.b / nrm)
    parts += [M >> 0 for M in lmi_expressions(cw.lmis, w)]
    prob = cp.Problem(cp.Minimize(cp.sum_squares(cp.multiply(g, w - robot.theta_true / s))), parts)
    try:
        solve_conic(prob, "the standard parameters of the exported URDF")
    except InfeasibleProblem:
        return None
    x = s * w.value
    x[base.independent] += beta - base.K @ x
    return x


def _metric(cov, k: int) -> np.ndarray:
    """C^-1 (k, k) for cov = C C^T: |C^-1 d|^2 = d^T cov^-1 d."""
    cov = as_matrix(cov, "cov", ncols=k)
    if cov.shape != (k, k):
        raise InputError(f"cov must be {k} x {k} (the estimate's covariance), got shape {cov.shape}.")
    try:
        C = np.linalg.cholesky(0.5 * (cov + cov.T))
    except np.linalg.LinAlgError:
        raise InputError("cov is not positive definite; the projection onto the physical set needs the estimate's "
                         "covariance (WLS, OLS).") from None
    return np.linalg.solve(C, np.eye(k))


@dataclass(frozen=True)
class Loadable:
    """The standard vector an export writes (:func:`loadable_standard`).

    standard : (p,) standard parameters whose links are rigid bodies (:func:`link_problems` is []).
    projected : False when they reproduce the given estimate (K standard = K theta with base
        parameters, standard = theta without), True when they are its projection onto the
        physical set (the estimate has no loadable standard vector).
    why : when projected, why the estimate itself cannot be written; active : the constraints
        active at the projection (labels); nearest : whether, of the standard vectors with its base
        parameters, this is the one nearest the URDF's values (False: the projection's own, the
        lifted solution, when Clarabel could not place that one within its tolerance).
    """

    standard: np.ndarray
    projected: bool
    why: str = ""
    active: tuple[str, ...] = ()
    nearest: bool = True


def loadable_standard(robot, theta, base: BaseParameters | None = None, cov=None) -> Loadable:
    """The standard vector to export for the estimate ``theta`` (p,) (module docstring).

    base : its base parameters (then only K theta counts: theta is any standard vector with those
        base parameters); cov : the estimate's covariance, (r, r) in base parameters or (p, p),
        needed only when the estimate has no loadable standard vector and must be projected.
    Raises InputError when the estimate has none and no usable ``cov`` is given, SolverError when
    the solver's answer fails the check of every link.
    """
    theta = as_vector(theta, "theta", robot.p)
    problems = link_problems(robot, theta)
    if base is None and not problems:
        return Loadable(theta.copy(), False)
    if base is not None:
        x = _nearest_standard(robot, export_constraints(robot), base, base.base(theta))
        if x is not None:
            return Loadable(_checked(robot, x), False)
        why = (f"no standard parameters with these base parameters make every link a rigid body (margin "
               f"{LINK_MARGIN:g} of the URDF's pseudo-inertia)")
        if problems:
            why += " (with the others at their URDF values: " + "; ".join(problems) + ")"
    else:
        why = "; ".join(problems)
    if cov is None:
        raise InputError(f"not written as a URDF, which pinocchio or MuJoCo would refuse or misread: {why}. Export "
                         "a physically consistent estimate (boundid.estimators.physical.physical_least_squares), or "
                         "give the estimate's covariance to export its projection onto the physical set.")
    hat = theta if base is None else base.base(theta)
    C_inv = _metric(cov, hat.shape[0])
    cons = export_constraints(robot, 2 * LINK_MARGIN)
    lifted_cons = cons if base is None else cons.lifted(base.K, base.symbols)
    fit, lifted, active = constrained_fit(C_inv, C_inv @ hat, lifted_cons)
    x = fit if base is None else _nearest_standard(robot, export_constraints(robot), base, fit)
    nearest = base is None or (x is not None and not link_problems(robot, x))
    if not nearest:
        # the set {x : K x = fit, margin} is thin (fit has the double margin only on its active links), and
        # Clarabel's answer can miss it by its tolerance: the fit's own standard vector is one of its points
        x = lifted
    return Loadable(_checked(robot, x), True, why, active, nearest)


def _checked(robot, x: np.ndarray) -> np.ndarray:
    problems = link_problems(robot, x)
    if problems:
        raise SolverError("the solver's standard parameters for the URDF fail the rigid-body check: "
                          + "; ".join(problems) + ". Report the case.")
    return x


def _comment(text: str) -> ET.Comment:
    """An XML comment (``--`` is not allowed inside one)."""
    return ET.Comment(" " + text.replace("--", "- -") + " ")


def _set_inertial(link: ET.Element, pi: np.ndarray) -> None:
    """Replace the link's <inertial> by mass, COM and inertia about the COM from parameters pi (10,), m > 0."""
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


def write_urdf(robot, theta, path: str | Path, note: str = "") -> Path:
    """Write a copy of ``robot``'s URDF with the inertias and friction of ``theta`` (p,), ``note`` as
    a comment at the top of <robot>; returns the path. Refused (InputError, nothing written) when a
    link would not be a rigid body (:func:`link_problems`)."""
    theta = as_vector(theta, "theta", robot.p)
    out = Path(path)
    if out.resolve() == robot.urdf_path.resolve():
        raise InputError(f"refusing to overwrite the source URDF {out}; write the identified copy elsewhere.")
    problems = link_problems(robot, theta)
    if problems:
        raise InputError("not written as a URDF, which pinocchio or MuJoCo would refuse or misread: "
                         + "; ".join(problems) + ". Check the identified parameters (or the attached links).")
    tree = ET.parse(robot.urdf_path)
    root = tree.getroot()
    links = {e.get("name"): e for e in root.findall("link")}
    joints = {e.get("name"): e for e in root.findall("joint")}
    attached = attached_parameters(robot)
    names = robot.param_names
    for j in range(robot.n_joints):
        _set_inertial(links[robot.link_names[j]], theta[10 * j:10 * j + 10] - attached[j])
        joint = joints[robot.joint_names[j]]
        dyn = joint.find("dynamics")
        if dyn is None:
            dyn = ET.SubElement(joint, "dynamics")
        dyn.set("damping", repr(float(theta[names.index(f"fv{j + 1}")])))
        dyn.set("friction", repr(float(theta[names.index(f"fc{j + 1}")])))
    if note:
        root.insert(0, _comment(note))
    ET.indent(tree)
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out


def write_mjcf(robot, theta, path: str | Path, note: str = "") -> Path:
    """Write the MJCF fragment of the joints of ``theta`` (p,): one default class per joint, named
    after it, holding <joint armature damping frictionloss> [kg m^2 or kg, N m s/rad or N s/m, N m
    or N] (armature only when the model identifies it), with ``note`` and how to apply it as a
    comment; returns the path."""
    theta = as_vector(theta, "theta", robot.p)
    names = robot.param_names
    root = ET.Element("mujoco", model=f"{robot.name}_identified")
    if note:
        root.append(_comment(note))
    urdf, me = f"{robot.name}_identified.urdf", Path(path).name
    root.append(_comment(
        "MuJoCo reads the URDF's <dynamics damping friction> as joint damping and frictionloss, but a URDF has no "
        "armature (the rotor inertia a joint adds to M(q)_jj); this file holds all three per joint, as a default "
        f"class named after the joint. Python (MuJoCo >= 3.2): spec = mujoco.MjSpec.from_file('{urdf}') (with the "
        f"compiler options its meshes need); d = mujoco.MjSpec.from_file('{me}'); for each joint j in spec.joints "
        "with c = d.find_default(j.name): j.armature, j.damping, j.frictionloss = c.joint.armature, c.joint.damping, "
        f"c.joint.frictionloss; model = spec.compile(). MJCF (e.g. spec.to_xml() of the URDF): <include "
        f"file=\"{me}\"/> inside <mujoco>, and class=\"<joint name>\" on each joint named here, without its own "
        "damping and frictionloss attributes (they would win over the class). Not here: torque offsets and coupled "
        "motors' parameters (tables only); a joint without armature has none identified."))
    default = ET.SubElement(root, "default")
    for j, joint in enumerate(robot.joint_names, start=1):
        attrs = {}
        if f"Ia{j}" in names:
            attrs["armature"] = repr(float(theta[names.index(f"Ia{j}")]))
        attrs["damping"] = repr(float(theta[names.index(f"fv{j}")]))
        attrs["frictionloss"] = repr(float(theta[names.index(f"fc{j}")]))
        ET.SubElement(ET.SubElement(default, "default", {"class": joint}), "joint", attrs)
    tree = ET.ElementTree(root)
    ET.indent(tree)
    out = Path(path)
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out


def parameter_table(robot, theta, base: BaseParameters | None = None, standard: bool = True) -> pd.DataFrame:
    """Rows (set, name, unit, value): the standard vector ``theta`` (p,) (unless ``standard`` is
    False: for an estimate whose split into standard parameters means nothing), then K theta if
    ``base`` is given."""
    theta = as_vector(theta, "theta", robot.p)
    rows = []
    if standard:
        rows += [("standard", nm, u, float(v)) for nm, u, v in zip(robot.param_names, robot.param_units, theta,
                                                                    strict=True)]
    if base is not None:
        rows += [("base", nm, u, float(v)) for nm, u, v in zip(base.names, base.units, base.base(theta), strict=True)]
    return pd.DataFrame(rows, columns=["set", "name", "unit", "value"])


def write_parameters(robot, theta, path: str | Path, base: BaseParameters | None = None, estimate: str = "",
                     standard: bool = True) -> Path:
    """Write :func:`parameter_table` to ``path``: CSV (.csv) or YAML (.yaml/.yml, with robot, URDF,
    joints and ``estimate``, what the values are, when given)."""
    out = Path(path)
    table = parameter_table(robot, theta, base, standard)
    if out.suffix == ".csv":
        table.to_csv(out, index=False, float_format="%.17g")
    elif out.suffix in (".yaml", ".yml"):
        doc = {"robot": robot.name, "urdf": str(robot.urdf_path), "joints": list(robot.joint_names)}
        if estimate:
            doc["estimate"] = estimate
        for kind, group in table.groupby("set", sort=False):
            doc[kind] = [{"name": r.name, "unit": r.unit, "value": r.value} for r in group.itertuples()]
        out.write_text(yaml.safe_dump(doc, sort_keys=False))
    else:
        raise InputError(f"unknown table format {out.suffix!r} for {out}; use .csv, .yaml or .yml.")
    return out


def export_files(robot, theta, folder: str | Path, base: BaseParameters | None = None,
                 estimate: str = "identified parameters", cov=None) -> list[Path]:
    """Export the estimate ``theta`` (p,) into ``folder``: the standard vector of
    :func:`loadable_standard` as ``<name>_identified.urdf``, ``<name>_mujoco.xml`` (:func:`write_mjcf`)
    and ``<name>_identified.yaml``/``.csv`` (with K x when ``base`` is given); when that vector is
    the estimate's projection, the estimate itself in ``<name>_unconstrained.yaml``/``.csv`` only
    (its base parameters, or its standard ones without ``base``). ``estimate`` says what theta is
    (e.g. "the WLS centre on the inverse_dynamic regression"), in every file's header; ``cov`` as
    for :func:`loadable_standard`. Returns the paths, in that order."""
    folder = Path(folder)
    chosen = loadable_standard(robot, theta, base, cov)
    x, name = chosen.standard, robot.name
    raw = f"{name}_unconstrained"
    if chosen.projected:
        what = (f"the projection of {estimate} onto the physical set: {estimate} itself is not written as a URDF "
                f"({chosen.why}; it is in {raw}.yaml and {raw}.csv only); this is the least squares in its "
                "covariance metric under the links' rigid-body constraints (LMI-constrained least squares), active: "
                + (", ".join(chosen.active) or "none"))
    else:
        what = estimate
    mapped = ("" if base is None else " The base parameters fix combinations of the standard ones only: written are "
              + ("the standard parameters nearest this URDF's values whose links are rigid bodies, the armature (a "
                 "joint property) taking what a combination leaves." if chosen.nearest else
                 "the projection's own standard parameters (the lifted solution of the constrained fit; the ones "
                 "nearest this URDF's values could not be placed within the solver's tolerance)."))
    urdf_note = (f"boundid export of {name}: {what}.{mapped} Every link written is a rigid body (mass > 0, principal "
                 "moments with A + B > C): pinocchio and MuJoCo load it as is, without balanceinertia. <dynamics "
                 f"damping friction>: viscous and Coulomb friction. Armature: in {name}_mujoco.xml.")
    stem = f"{name}_identified"
    paths = [write_urdf(robot, x, folder / f"{stem}.urdf", urdf_note),
             write_mjcf(robot, x, folder / f"{name}_mujoco.xml", f"boundid export of {name}: {what}."),
             write_parameters(robot, x, folder / f"{stem}.yaml", base, what),
             write_parameters(robot, x, folder / f"{stem}.csv", base)]
    if chosen.projected:
        note = f"{estimate}, not physically consistent ({chosen.why}): tables only"
        paths += [write_parameters(robot, theta, folder / f"{raw}.yaml", base, note, standard=base is None),
                  write_parameters(robot, theta, folder / f"{raw}.csv", base, standard=base is None)]
    return paths
