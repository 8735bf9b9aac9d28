"""Physical constraints on a parameter vector, as data: linear rows, second-order cones, LMIs.

A model says what its parameters can be (a mass is >= 0, a friction dissipates, a rigid body has
a positive semidefinite pseudo-inertia [WensingKimSlotine2018]) by returning a
:class:`PhysicalConstraints` on a variable x (n,):

    linear rows      A x <= b                                  (:class:`LinearRows`)
    cones            ||G x + g||_2 <= f^T x + d                 (:class:`Cone`)
    LMIs             F0 + sum_i x_i F_i  positive semidefinite  (:class:`MatrixInequality`)

The parameters are theta = x (``lift`` None) or, for base parameters [SousaCortesao2014],
theta = K x with x the standard parameters: the constraints live on x, and the set of physically
consistent theta is the projection {K x : x satisfies every constraint}. It is kept in that lifted
form: a constraint on the standard parameters says nothing checkable about one theta without
searching for an x (:func:`boundid.sets.physical.physical_margin` does that search).

Each constraint carries a short ``label`` ("Imot1 >= 0") and a ``reason`` (its derivation), so a
page or an error message can say why a value is impossible.

:meth:`PhysicalConstraints.check` measures each constraint's violation at x as a lower bound on
the Euclidean distance from x to that constraint's set, in x's units (exact for a linear row,
the violation divided by the constraint's Lipschitz constant for cones and LMIs): > 0 means
violated.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from boundid._validation import as_float_array, as_matrix, as_vector
from boundid.errors import InputError


@dataclass(frozen=True)
class LinearRows:
    """Rows a_i^T x <= b_i, each with a label and a reason.

    A : (m, n), b : (m,), labels, reasons : (m,) strings.
    """

    A: np.ndarray
    b: np.ndarray
    labels: tuple[str, ...]
    reasons: tuple[str, ...]

    @property
    def m(self) -> int:
        return int(self.b.shape[0])


@dataclass(frozen=True)
class Cone:
    """The second-order cone ||G x + g||_2 <= f^T x + d.

    A rotated cone u v >= |w|^2, u, v >= 0 is ||(2 w, u - v)|| <= u + v.
    G : (k, n), g : (k,), f : (n,), d : float.
    """

    G: np.ndarray
    g: np.ndarray
    f: np.ndarray
    d: float
    label: str
    reason: str

    def value(self, X: np.ndarray) -> np.ndarray:
        """||G x + g|| - f^T x - d for each row x of X (m, n) (<= 0: satisfied)."""
        return np.linalg.norm(X @ self.G.T + self.g, axis=1) - X @ self.f - self.d

    @property
    def lipschitz(self) -> float:
        """||G||_2 + ||f||: the violation changes by at most this per unit move of x."""
        return float(np.linalg.norm(self.G, 2) + np.linalg.norm(self.f))


@dataclass(frozen=True)
class MatrixInequality:
    """The LMI F(x) = F0 + sum_i x_i F[i] >= 0 (positive semidefinite).

    F0 : (k, k) symmetric, F : (n, k, k) symmetric.
    """

    F0: np.ndarray
    F: np.ndarray
    label: str
    reason: str

    def matrix(self, x: np.ndarray) -> np.ndarray:
        """F(x), (k, k)."""
        return self.F0 + np.tensordot(x, self.F, axes=1)

    def value(self, X: np.ndarray) -> np.ndarray:
        """-lambda_min(F(x)) for each row x of X (m, n) (<= 0: satisfied)."""
        M = self.F0[None] + np.tensordot(X, self.F, axes=1)
        return -np.linalg.eigvalsh(0.5 * (M + np.swapaxes(M, 1, 2)))[:, 0]

    @property
    def lipschitz(self) -> float:
        """sqrt(sum_i ||F_i||_2^2): |lambda_min(F(x)) - lambda_min(F(x'))| <= this |x - x'|."""
        return float(np.sqrt(sum(np.linalg.norm(Fi, 2) ** 2 for Fi in self.F)))


@dataclass(frozen=True)
class Check:
    """The constraints evaluated at one point.

    ok : every violation <= tol.
    worst : the largest violation (a lower bound on the distance to that constraint's set, in x's
        units; <= 0 when satisfied, e.g. -Imot1 for Imot1 >= 0).
    which : label of the constraint with the worst violation ("" if there are no constraints).
    violations : (n_constraints,) every violation, in the order of ``labels``.
    labels : (n_constraints,) linear rows first, then cones, then LMIs.
    """

    ok: bool
    worst: float
    which: str
    violations: np.ndarray
    labels: tuple[str, ...]

    def violated(self, tol: float = 0.0) -> tuple[str, ...]:
        """Labels of the constraints violated by more than ``tol``."""
        return tuple(lab for lab, v in zip(self.labels, self.violations, strict=True) if v > tol)


def _empty_rows(n: int) -> LinearRows:
    return LinearRows(np.zeros((0, n)), np.zeros(0), (), ())


@dataclass(frozen=True)
class PhysicalConstraints:
    """Linear rows, cones and LMIs on a variable x (n,); the parameters are theta = x or K x.

    names : (n,) names of the variables x.
    linear : :class:`LinearRows` (possibly with 0 rows).
    cones : second-order cones; lmis : linear matrix inequalities.
    lift : None (theta = x) or K (p, n) with theta = K x (base parameters of standard ones).
    param_names : (p,) names of theta (= names when not lifted).
    scale : (n,) typical magnitude of each x_j (> 0), used only to scale a solver's coordinates
        when theta does not determine x (lifted constraints); None: unknown.
    """

    names: tuple[str, ...]
    linear: LinearRows
    cones: tuple[Cone, ...] = ()
    lmis: tuple[MatrixInequality, ...] = ()
    lift: np.ndarray | None = None
    param_names: tuple[str, ...] = ()
    scale: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        n = len(self.names)
        if self.linear.A.shape != (self.linear.m, n):
            raise InputError(f"linear rows must have {n} columns, got shape {self.linear.A.shape}.")
        for c in self.cones:
            if c.G.shape[1] != n or c.f.shape != (n,):
                raise InputError(f"cone {c.label!r} must act on {n} variables.")
        for L in self.lmis:
            if L.F.shape[0] != n or L.F.shape[1:] != L.F0.shape:
                raise InputError(f"LMI {L.label!r} must have {n} coefficient matrices of F0's shape.")
        if self.lift is not None and self.lift.shape[1] != n:
            raise InputError(f"lift must have {n} columns, got shape {self.lift.shape}.")
        if not self.param_names:
            object.__setattr__(self, "param_names", self.names if self.lift is None else
                               tuple(f"theta{i + 1}" for i in range(self.lift.shape[0])))
        if self.scale is not None and (self.scale.shape != (n,) or np.any(~(self.scale > 0))):
            raise InputError(f"scale must be {n} finite values > 0.")

    # ------------------------------------------------------------------ sizes and kinds
    @property
    def dim(self) -> int:
        """n, the number of variables x the constraints act on."""
        return len(self.names)

    @property
    def n_params(self) -> int:
        """p, the number of parameters theta (= n unless lifted)."""
        return self.dim if self.lift is None else int(self.lift.shape[0])

    @property
    def is_linear(self) -> bool:
        """Only linear rows (an LP can handle them)."""
        return not self.cones and not self.lmis

    @property
    def is_lifted(self) -> bool:
        """theta = K x with K not the identity: theta alone does not determine x."""
        return self.lift is not None and not (self.lift.shape[0] == self.lift.shape[1]
                                              and np.array_equal(self.lift, np.eye(self.dim)))

    @property
    def labels(self) -> tuple[str, ...]:
        return self.linear.labels + tuple(c.label for c in self.cones) + tuple(L.label for L in self.lmis)

    @property
    def reasons(self) -> tuple[str, ...]:
        return self.linear.reasons + tuple(c.reason for c in self.cones) + tuple(L.reason for L in self.lmis)

    def __len__(self) -> int:
        return len(self.labels)

    def __repr__(self) -> str:
        lift = f", lifted to {self.n_params} parameters" if self.is_lifted else ""
        return (f"PhysicalConstraints(dim={self.dim}, {self.linear.m} linear, {len(self.cones)} cones, "
                f"{len(self.lmis)} LMIs{lift})")

    def describe(self) -> str:
        """One line per constraint: label, then its derivation."""
        head = f"{len(self)} physical constraints on {self.dim} variables"
        if self.is_lifted:
            head += f" (standard parameters; the {self.n_params} parameters are theta = K x)"
        return "\n".join([head] + [f"  {lab}: {why}" for lab, why in zip(self.labels, self.reasons, strict=True)])

    # ------------------------------------------------------------------ evaluation
    def violations(self, points) -> np.ndarray:
        """(m, n_constraints) violations at each row of ``points`` (m, n) (see :class:`Check`)."""
        X = np.atleast_2d(as_float_array(points, "x"))
        if X.shape[1] != self.dim or not np.all(np.isfinite(X)):
            raise InputError(f"x must be finite with {self.dim} entries ({', '.join(self.names[:4])}...), "
                             f"got shape {X.shape}.")
        lin = self.linear
        parts = [(X @ lin.A.T - lin.b) / np.linalg.norm(lin.A, axis=1)]
        parts += [(c.value(X) / c.lipschitz)[:, None] for c in self.cones]
        parts += [(L.value(X) / L.lipschitz)[:, None] for L in self.lmis]
        return np.hstack(parts) if parts else np.zeros((X.shape[0], 0))

    def check(self, x, tol: float = 0.0) -> Check:
        """Every constraint at x (n,): (ok, worst violation, which constraint, all violations)."""
        x = as_vector(x, "x", self.dim)
        v = self.violations(x)[0]
        if v.size == 0:
            return Check(True, -np.inf, "", v, ())
        k = int(np.argmax(v))
        return Check(bool(v[k] <= tol), float(v[k]), self.labels[k], v, self.labels)

    # ------------------------------------------------------------------ composition
    def __and__(self, other: PhysicalConstraints) -> PhysicalConstraints:
        """Both sets of constraints on the same variables (same names and lift)."""
        if not isinstance(other, PhysicalConstraints) or other.names != self.names:
            raise InputError("only constraints on the same variables (same names) can be combined.")
        if (self.lift is None) != (other.lift is None) or (self.lift is not None
                                                           and not np.array_equal(self.lift, other.lift)):
            raise InputError("constraints with different lifts cannot be combined; combine them before lifting.")
        lin = LinearRows(np.vstack([self.linear.A, other.linear.A]), np.concatenate([self.linear.b, other.linear.b]),
                         self.linear.labels + other.linear.labels, self.linear.reasons + other.linear.reasons)
        scale = self.scale if self.scale is not None else other.scale
        return replace(self, linear=lin, cones=self.cones + other.cones, lmis=self.lmis + other.lmis, scale=scale)

    def lifted(self, K, param_names=None) -> PhysicalConstraints:
        """The same constraints with parameters theta = K x (K (p, n); composed with an existing lift)."""
        K = as_matrix(K, "K", ncols=self.n_params)
        lift = K if self.lift is None else K @ self.lift
        names = tuple(param_names) if param_names is not None else tuple(f"theta{i + 1}" for i in range(K.shape[0]))
        if len(names) != K.shape[0]:
            raise InputError(f"{len(names)} parameter names for {K.shape[0]} parameters.")
        return replace(self, lift=lift, param_names=names)

    def in_coordinates(self, x0, M) -> PhysicalConstraints:
        """The constraints on v with x = x0 + M v (M (n, k)), not lifted: what a solver sees in its
        own (scaled, shifted) coordinates. Linear rows: (A M) v <= b - A x0; cones: G -> G M,
        g -> g + G x0, f -> M^T f, d -> d + f^T x0; LMIs: F0 -> F(x0), F_j -> sum_i M_ij F_i."""
        x0 = as_vector(x0, "x0", self.dim)
        M = as_matrix(M, "M")
        if M.shape[0] != self.dim:
            raise InputError(f"M must have {self.dim} rows, got shape {M.shape}.")
        k = M.shape[1]
        lin = self.linear
        new_lin = LinearRows(lin.A @ M, lin.b - lin.A @ x0, lin.labels, lin.reasons)
        cones = tuple(Cone(c.G @ M, c.g + c.G @ x0, M.T @ c.f, float(c.d + c.f @ x0), c.label, c.reason)
                      for c in self.cones)
        lmis = tuple(MatrixInequality(L.matrix(x0), np.tensordot(M.T, L.F, axes=1), L.label, L.reason)
                     for L in self.lmis)
        return PhysicalConstraints(tuple(f"v{j + 1}" for j in range(k)), new_lin, cones, lmis)


# ---------------------------------------------------------------------- builders
def linear_rows(A, b, labels, reasons, n: int | None = None) -> LinearRows:
    """Checked :class:`LinearRows` (A (m, n), b (m,), one label and one reason per row)."""
    labels, reasons = tuple(labels), tuple(reasons)
    if len(labels) == 0 and n is not None:
        return _empty_rows(n)
    A = as_matrix(A, "A", ncols=n)
    b = as_vector(b, "b", A.shape[0])
    if len(labels) != A.shape[0] or len(reasons) != A.shape[0]:
        raise InputError(f"give one label and one reason per row ({A.shape[0]} rows).")
    if A.shape[0] and np.any(np.linalg.norm(A, axis=1) == 0):
        raise InputError("a linear row is all zeros; drop it (0 <= b is not a constraint on x).")
    return LinearRows(A, b, labels, reasons)


def nonnegative(names, which, reasons) -> LinearRows:
    """x_j >= 0 (as -x_j <= 0) for each index j in ``which``, labelled "name >= 0"."""
    n = len(names)
    which = list(which)
    A = np.zeros((len(which), n))
    A[np.arange(len(which)), which] = -1.0
    return linear_rows(A, np.zeros(len(which)), [f"{names[j]} >= 0" for j in which], reasons, n)


def pseudo_inertia(n: int, start: int, label: str, reason: str) -> MatrixInequality:
    """The pseudo-inertia LMI of a rigid body [WensingKimSlotine2018] whose 10 standard parameters
    sit at x[start:start + 10] in pinocchio's order [m, hx, hy, hz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]
    (h = m c, I about the frame origin):

        J = [[Sigma, h], [h^T, m]] >= 0,   Sigma = 1/2 tr(I) 1_3 - I  (= the integral of r r^T dm)

    J is linear in the parameters; a body with a nonnegative mass density having these
    parameters exists iff J is positive semidefinite (J > 0 for a body with a 3-D extent)."""
    F = np.zeros((n, 4, 4))
    m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = range(start, start + 10)
    F[m][3, 3] = 1.0
    for k, j in enumerate((hx, hy, hz)):
        F[j][k, 3] = F[j][3, k] = 1.0
    # Sigma = 0.5 (Ixx + Iyy + Izz) 1 - I
    for j, (a, b) in ((ixx, (0, 0)), (iyy, (1, 1)), (izz, (2, 2))):
        F[j][:3, :3] += 0.5 * np.eye(3)
        F[j][a, b] -= 1.0
    for j, (a, b) in ((ixy, (0, 1)), (ixz, (0, 2)), (iyz, (1, 2))):
        F[j][a, b] = F[j][b, a] = -1.0
    return MatrixInequality(np.zeros((4, 4)), F, label, reason)


def constraints(names, linear: LinearRows | None = None, cones=(), lmis=(), scale=None) -> PhysicalConstraints:
    """A :class:`PhysicalConstraints` on variables named ``names`` (theta = x)."""
    names = tuple(str(s) for s in names)
    linear = _empty_rows(len(names)) if linear is None else linear
    scale = None if scale is None else as_vector(scale, "scale", len(names))
    return PhysicalConstraints(names, linear, tuple(cones), tuple(lmis), scale=scale)
