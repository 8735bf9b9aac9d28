"""H4 parallel robot kinematics: geometry, closed-form inverse model, Jacobian, Newton forward model.

[H4Paper] (section II.A) gives the structure but not the dimensions (they are not
public); the geometry below is the one chosen for this project (docs/models.md):

    alpha = (0, pi, 3pi/2, 3pi/2)          u = (+y, -y, +x, +x)          (paper, section II.A)
    v_i = (cos alpha_i, sin alpha_i, 0),   w_i = u_i x v_i (= -z)
    P_i = R v_i + o_i                      motor i (o_3 = (-s, 0, 0), o_4 = (+s, 0, 0))
    B_i(q_i) = P_i + L (cos q_i v_i + sin q_i w_i)                          elbow
    A_i(x) = D + side_i d (cos th, sin th, 0) + updown_i h (0, 1, 0)        nacelle attachment
    |A_i(x) - B_i(q_i)|^2 = l^2                                             closure of chain i

with the pose x = (x, y, z, th) (m, m, m, rad), D = (x, y, z), motor angles q (rad). Differentiating
the closures gives Jx xd = Jq qd, J = Jx^-1 Jq (paper eq. 11), and the forward model is the
Newton iteration x_{n+1} = x_n + J(x_n, q_n)(q - q_n), q_n = IK(x_n) (paper eq. 10).

Every function is vectorised over N poses: poses (N, 4), angles (N, 4), Jacobians (N, 4, 4); a
single pose (4,) is accepted and gives unbatched output.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from boundid._validation import as_float_array
from boundid.errors import InputError, UnreachablePoseError
from boundid.models import _h4_kernels

_AXES = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0), "-y": (0.0, -1.0, 0.0)}


@dataclass(frozen=True)
class H4Geometry:
    """Dimensions of the H4 robot (m, rad). Defaults: the project's choice (docs/models.md).

    R : motor radius; L : arm (motor-to-elbow) length; l : forearm (elbow-to-nacelle) length;
    d, h : half lengths of the "H" nacelle; s : offset of motors 3 and 4 along x.
    alpha, axes, side, updown : chain layout (paper section II.A, ``axes`` from "+x" "-x" "+y" "-y").
    workspace_low/high : the box (x, y, z, th) the robot is used in (m, m, m, rad).
    home : a pose inside the workspace, the default start of the Newton forward model.
    cond_max : poses whose Jacobian J has a 2-norm condition number above this are treated as
        near-singular (UnreachablePoseError). cond(J) stays below about 40 inside the default box.
    """

    R: float = 0.25
    L: float = 0.30
    l: float = 0.80
    d: float = 0.12
    h: float = 0.06
    s: float = 0.12
    alpha: tuple[float, float, float, float] = (0.0, np.pi, 1.5 * np.pi, 1.5 * np.pi)
    axes: tuple[str, str, str, str] = ("+y", "-y", "+x", "+x")
    side: tuple[float, float, float, float] = (1.0, -1.0, -1.0, 1.0)
    updown: tuple[float, float, float, float] = (1.0, 1.0, -1.0, -1.0)
    workspace_low: tuple[float, float, float, float] = (-0.15, -0.15, -0.90, -0.5)
    workspace_high: tuple[float, float, float, float] = (0.15, 0.15, -0.60, 0.5)
    home: tuple[float, float, float, float] = (0.0, 0.0, -0.75, 0.0)
    cond_max: float = 1.0e3
    # derived arrays (filled in __post_init__)
    P: np.ndarray = field(init=False, repr=False, compare=False)
    V: np.ndarray = field(init=False, repr=False, compare=False)
    W: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        for nm in ("R", "L", "l", "d", "h"):
            val = getattr(self, nm)
            if not (np.isfinite(val) and val > 0):
                raise InputError(f"H4Geometry.{nm} must be a positive length in m, got {val}.")
        if not np.isfinite(self.s):
            raise InputError(f"H4Geometry.s must be finite, got {self.s}.")
        if any(a not in _AXES for a in self.axes) or len(self.axes) != 4:
            raise InputError(f"H4Geometry.axes must be 4 of {sorted(_AXES)}, got {self.axes}.")
        lo, hi = np.asarray(self.workspace_low, float), np.asarray(self.workspace_high, float)
        if lo.shape != (4,) or hi.shape != (4,) or np.any(lo >= hi):
            raise InputError("workspace_low/high must be 4 values each with low < high (x, y, z, th).")
        if not (np.all(lo <= self.home) and np.all(np.asarray(self.home) <= hi)):
            raise InputError(f"home pose {self.home} must lie inside the workspace box.")
        if not self.cond_max > 1:
            raise InputError(f"cond_max must be > 1, got {self.cond_max}.")
        a = np.asarray(self.alpha, float)
        V = np.stack([np.cos(a), np.sin(a), np.zeros(4)], axis=1)
        U = np.array([_AXES[k] for k in self.axes])
        W = np.cross(U, V)
        if np.any(np.abs(np.linalg.norm(W, axis=1) - 1) > 1e-9):
            raise InputError("each arm axis u_i must be orthogonal to its motor direction v_i.")
        offsets = np.zeros((4, 3))
        offsets[2, 0], offsets[3, 0] = -self.s, self.s
        object.__setattr__(self, "P", self.R * V + offsets)
        object.__setattr__(self, "V", np.where(np.abs(V) < 1e-15, 0.0, V))
        object.__setattr__(self, "W", np.where(np.abs(W) < 1e-15, 0.0, W))


@dataclass(frozen=True)
class ChainKinematics:
    """Points and derivatives of the four chains at N poses (all arrays batched over N).

    A, B : (N, 4, 3) attachment points and elbows (m); dA : (N, 4, 3, 4) dA_i/dx;
    dB : (N, 4, 3) dB_i/dq_i (m/rad); Jx : (N, 4, 4); jq : (N, 4) diagonal of Jq; J : (N, 4, 4).
    """

    x: np.ndarray
    q: np.ndarray
    A: np.ndarray
    B: np.ndarray
    dA: np.ndarray
    dB: np.ndarray
    Jx: np.ndarray
    jq: np.ndarray
    J: np.ndarray


class H4Kinematics:
    """Inverse, differential and forward kinematics of the H4 robot for a :class:`H4Geometry`."""

    def __init__(self, geometry: H4Geometry | None = None):
        if geometry is not None and not isinstance(geometry, H4Geometry):
            raise InputError(f"geometry must be an H4Geometry, got {type(geometry).__name__}.")
        self.geometry = geometry or H4Geometry()

    # -- input handling -------------------------------------------------------------------
    @staticmethod
    def _batch(a, name: str) -> tuple[np.ndarray, bool]:
        a = as_float_array(a, name)
        single = a.ndim == 1
        a = np.atleast_2d(a)
        if a.ndim != 2 or a.shape[1] != 4:
            raise InputError(f"{name} must have shape (N, 4) or (4,), got {np.shape(a)}.")
        if not np.all(np.isfinite(a)):
            raise InputError(f"{name} contains NaN or infinite values.")
        return a, single

    # -- points ---------------------------------------------------------------------------
    def attachments(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A_i(x) (N, 4, 3) and dA_i/dx (N, 4, 3, 4) for poses x (N, 4)."""
        g = self.geometry
        side, updown = np.asarray(g.side), np.asarray(g.updown)
        c, s = np.cos(x[:, 3]), np.sin(x[:, 3])
        e = np.stack([c, s, np.zeros_like(c)], axis=1)  # (N, 3) H direction
        de = np.stack([-s, c, np.zeros_like(c)], axis=1)  # d e / d th
        A = (x[:, None, :3] + g.d * side[None, :, None] * e[:, None, :]
             + g.h * updown[None, :, None] * np.array([0.0, 1.0, 0.0]))
        dA = np.zeros(x.shape[:1] + (4, 3, 4))
        dA[..., :3] = np.eye(3)
        dA[..., 3] = g.d * side[None, :, None] * de[:, None, :]
        return A, dA

    def elbows(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """B_i(q_i) (N, 4, 3) and dB_i/dq_i (N, 4, 3) for motor angles q (N, 4)."""
        g = self.geometry
        c, s = np.cos(q)[..., None], np.sin(q)[..., None]
        B = g.P + g.L * (c * g.V + s * g.W)
        dB = g.L * (-s * g.V + c * g.W)
        return B, dB

    # -- inverse model --------------------------------------------------------------------
    def _ik(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form IK; returns q (N, 4) (NaN where unreachable) and the margin |k| / hypot(a, b)."""
        g = self.geometry
        A, _ = self.attachments(x)
        e = A - g.P
        k = (np.einsum("nij,nij->ni", e, e) + g.L**2 - g.l**2) / (2 * g.L)
        a = np.einsum("nij,ij->ni", e, g.V)
        b = np.einsum("nij,ij->ni", e, g.W)
        ratio = k / np.hypot(a, b)
        with np.errstate(invalid="ignore"):
            q = np.arctan2(b, a) - np.arccos(ratio)
        return q, ratio

    def inverse_kinematics(self, x) -> np.ndarray:
        """Motor angles q (N, 4) [rad] of poses x (N, 4) [m, m, m, rad], closed form per chain.

        q_i = atan2(b, a) - acos(k / hypot(a, b)), e = A_i - P_i, a = e.v_i, b = e.w_i,
        k = (|e|^2 + L^2 - l^2) / (2L). Raises UnreachablePoseError where |k| > hypot(a, b).
        """
        x, single = self._batch(x, "x")
        q, ratio = self._ik(x)
        bad = ~(np.abs(ratio) <= 1.0)
        if np.any(bad):
            n, i = np.argwhere(bad)[0]
            raise UnreachablePoseError(
                f"pose x = {np.array2string(x[n], precision=4)} (sample {n}) is unreachable: chain {i + 1} "
                f"would need a forearm longer than l = {self.geometry.l} m ({int(bad.any(1).sum())} of "
                f"{len(x)} poses affected). Keep poses inside the workspace box "
                f"{self.geometry.workspace_low} .. {self.geometry.workspace_high}."
            )
        return q[0] if single else q

    # -- differential model ---------------------------------------------------------------
    def chains(self, x, q=None, check: bool = True) -> ChainKinematics:
        """All chain quantities at poses x (N, 4); q = IK(x) unless given. ``check`` raises on singularity."""
        x, _ = self._batch(x, "x")
        q = self.inverse_kinematics(x) if q is None else self._batch(q, "q")[0]
        A, dA = self.attachments(x)
        B, dB = self.elbows(q)
        AB = A - B
        Jx = np.einsum("nij,nijk->nik", AB, dA)  # row i = (A_i - B_i)^T dA_i/dx
        jq = np.einsum("nij,nij->ni", AB, dB)  # Jq = diag((A_i - B_i)^T dB_i/dq_i)
        with np.errstate(all="ignore"):
            J = np.linalg.solve(Jx, np.eye(4) * jq[:, None, :])  # eq. (11), Jx^-1 Jq
        if check:
            self._check_singular(x, J)
        return ChainKinematics(x, q, A, B, dA, dB, Jx, jq, J)

    def condition(self, x, q=None) -> np.ndarray:
        """2-norm condition number of J at poses x, (N,) (inf at an exact singularity)."""
        J = self.chains(x, q, check=False).J
        c = np.full(len(J), np.inf)
        ok = np.all(np.isfinite(J), axis=(1, 2))
        c[ok] = np.linalg.cond(J[ok])
        return c

    def _check_singular(self, x: np.ndarray, J: np.ndarray):
        finite = np.all(np.isfinite(J), axis=(1, 2))
        cond = np.full(len(J), np.inf)
        cond[finite] = np.linalg.cond(J[finite])
        bad = ~(cond <= self.geometry.cond_max)
        if np.any(bad):
            n = int(np.argmax(bad))
            raise UnreachablePoseError(
                f"pose x = {np.array2string(x[n], precision=4)} (sample {n}) is too close to a singularity: "
                f"cond(J) = {cond[n]:.3g} > cond_max = {self.geometry.cond_max:g} ({int(bad.sum())} of {len(x)} "
                "poses affected). Move the nacelle back inside the workspace box or raise H4Geometry.cond_max."
            )

    def jacobian(self, x, q=None) -> np.ndarray:
        """J (N, 4, 4) with xd = J qd (paper eq. 11); raises UnreachablePoseError near singularities."""
        xs, single = self._batch(x, "x")
        J = self.chains(xs, q).J
        return J[0] if single else J

    def jacobian_dot(self, x, qd, q=None) -> np.ndarray:
        """Analytic dJ/dt (N, 4, 4) at poses x moving with motor velocities qd (rad/s).

        From Jx J = Jq: Jdot = Jx^-1 (Jq_dot - Jx_dot J), with xd = J qd,
        Jx_dot row i = (Ad_i - Bd_i)^T dA_i/dx + (A_i - B_i)^T d/dt(dA_i/dx),
        Jq_dot_ii = (Ad_i - Bd_i)^T dB_i/dq_i + (A_i - B_i)^T d2B_i/dq_i^2 qd_i.
        """
        xs, single = self._batch(x, "x")
        qd, _ = self._batch(qd, "qd")
        ck = self.chains(xs, q)
        Jd = self._jdot(ck, qd)
        return Jd[0] if single else Jd

    def _jdot(self, ck: ChainKinematics, qd: np.ndarray) -> np.ndarray:
        g = self.geometry
        xd = np.einsum("nij,nj->ni", ck.J, qd)
        Ad = np.einsum("nijk,nk->nij", ck.dA, xd)
        Bd = ck.dB * qd[..., None]
        c, s = np.cos(ck.x[:, 3]), np.sin(ck.x[:, 3])
        # d/dt of the th column of dA_i/dx: side_i d (-cos th, -sin th, 0) thd
        ddA = (g.d * np.asarray(g.side)[None, :, None]
               * np.stack([-c, -s, np.zeros_like(c)], axis=1)[:, None, :] * xd[:, 3, None, None])
        AB, ABd = ck.A - ck.B, Ad - Bd
        Jxd = np.einsum("nij,nijk->nik", ABd, ck.dA)
        Jxd[..., 3] += np.einsum("nij,nij->ni", AB, ddA)
        cq, sq = np.cos(ck.q)[..., None], np.sin(ck.q)[..., None]
        d2B = -g.L * (cq * g.V + sq * g.W)
        jqd = np.einsum("nij,nij->ni", ABd, ck.dB) + np.einsum("nij,nij->ni", AB, d2B) * qd
        rhs = np.eye(4) * jqd[:, None, :] - Jxd @ ck.J
        return np.linalg.solve(ck.Jx, rhs)

    def jacobian_dot_central(self, x, h: float) -> np.ndarray:
        """dJ/dt (N, 4, 4) by central differences of J along a pose trajectory x (N, 4) sampled every h s.

        This is the paper's choice (section II.B, after eq. 19); second-order one-sided at the ends.
        """
        xs, _ = self._batch(x, "x")
        if not (np.isfinite(h) and h > 0) or len(xs) < 3:
            raise InputError(f"need h > 0 s and at least 3 poses, got h = {h}, {len(xs)} poses.")
        return np.gradient(self.chains(xs).J, h, axis=0, edge_order=2)

    # -- forward model --------------------------------------------------------------------
    def _fk(self, q: np.ndarray, x0: np.ndarray, tol: float, max_iter: int):
        """Newton iteration of eq. (10), x_{k+1} = x_k + J(x_k) (q - IK(x_k)), for each sample from
        its x0; returns x and the converged mask (no raising). An iterate outside the reachable set
        (some chain too short) goes back half its last step. Compiled, one sample at a time
        (:func:`boundid.models._h4_kernels.fk_batch`: 5 us a pose against 30 us batched in numpy)."""
        g = self.geometry
        return _h4_kernels.fk_batch(np.ascontiguousarray(q), np.ascontiguousarray(x0), g.P, g.V, g.W,
                                    np.asarray(g.side, float), np.asarray(g.updown, float),
                                    np.array([g.L, g.l, g.d, g.h]), tol, max_iter)

    def forward_kinematics(self, q, x0=None, tol: float = 1e-12, max_iter: int = 30) -> np.ndarray:
        """Pose x (N, 4) reached with motor angles q (N, 4), by the Newton iteration of eq. (10).

        x0 : starting poses (N, 4) or (4,) (default the geometry's home pose); tol : stop when
        max_i |q_i - IK_i(x_n)| <= tol rad; max_iter : iteration cap. Raises UnreachablePoseError
        if some sample does not converge or ends near a singularity (cond(J) > cond_max).
        """
        q, single = self._batch(q, "q")
        if not (tol > 0 and int(max_iter) >= 1):
            raise InputError(f"tol must be > 0 rad and max_iter >= 1, got {tol}, {max_iter}.")
        x = self._converged_fk(q, x0, tol, int(max_iter))
        self._check_singular(x, self.chains(x, q, check=False).J)
        return x[0] if single else x

    def _converged_fk(self, q: np.ndarray, x0, tol: float, max_iter: int) -> np.ndarray:
        """x (N, 4) by :meth:`_fk` from x0 (default home); UnreachablePoseError where it does not converge."""
        x0 = np.broadcast_to(np.asarray(self.geometry.home if x0 is None else x0, float), q.shape)
        x, ok = self._fk(q, x0, tol, max_iter)
        if not ok.all():
            n = int(np.argmin(ok))
            raise UnreachablePoseError(
                f"forward kinematics did not converge for q = {np.array2string(q[n], precision=4)} rad "
                f"(sample {n}; {int((~ok).sum())} of {len(q)} samples) within {max_iter} Newton iterations "
                f"to {tol:g} rad: the motor angles are outside the reachable set or near a singularity."
            )
        return x

    def in_workspace(self, x) -> np.ndarray:
        """Boolean (N,): pose inside the workspace box of the geometry."""
        xs, single = self._batch(x, "x")
        g = self.geometry
        inside = np.all((xs >= g.workspace_low) & (xs <= g.workspace_high), axis=1)
        return inside[0] if single else inside
