"""Exciting trajectories: finite Fourier series in joint space (Swevers et al. 1997), rest-to-rest.

One joint j of a :class:`FourierTrajectory` of period T (w = 2 pi / T) and K harmonics is

    q_j(t) = q0_j + sum_k a_jk / (k w) sin(k w t) - b_jk / (k w) cos(k w t)          [rad]

a_jk, b_jk in rad/s. ``at_rest`` projects the coefficients so that q(0) = q0, qd(0) = qdd(0) = 0
(sum_k a_jk = 0, sum_k b_jk / k = 0, sum_k k b_jk = 0); such segments, each run for whole periods,
chain with continuous position, velocity and acceleration. The H4 paper's exciting motion has slow
parts (friction) and fast parts (inertia): :func:`exciting_trajectory` builds a slow segment and a
repeated fast one, scaled to stay in the robot's workspace (checked with the forward model), and
:func:`optimize_trajectory` lowers the condition number of the observation matrix (scipy.optimize).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import optimize

from boundid._validation import as_float_array, as_vector
from boundid.errors import InputError, UnreachablePoseError


@dataclass(frozen=True)
class FourierTrajectory:
    """Joint-space Fourier series; q0 (n,) rad, a and b (n, K) rad/s, period in s."""

    period: float
    q0: np.ndarray
    a: np.ndarray
    b: np.ndarray

    def __post_init__(self):
        if not (np.isfinite(self.period) and self.period > 0):
            raise InputError(f"period must be finite and > 0 s, got {self.period}.")
        q0 = as_vector(self.q0, "q0")
        a, b = as_float_array(self.a, "a"), as_float_array(self.b, "b")
        if a.ndim != 2 or a.shape != b.shape or a.shape[0] != len(q0) or a.shape[1] < 1:
            raise InputError(f"a and b must both be (n, K) with n = len(q0) = {len(q0)}; got {a.shape}, {b.shape}.")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            raise InputError("Fourier coefficients a, b contain NaN or infinite values.")
        object.__setattr__(self, "q0", q0)
        object.__setattr__(self, "a", a)
        object.__setattr__(self, "b", b)

    @property
    def harmonics(self) -> int:
        return self.a.shape[1]

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, qd, qdd at times t (N,) s, each (N, n)."""
        t = np.atleast_1d(as_float_array(t, "t"))
        w = 2.0 * np.pi / self.period
        k = np.arange(1, self.harmonics + 1)
        s, c = np.sin(w * np.outer(t, k)), np.cos(w * np.outer(t, k))  # (N, K)
        kw = k * w
        q = self.q0 + s @ (self.a / kw).T - c @ (self.b / kw).T
        qd = c @ self.a.T + s @ self.b.T
        qdd = -s @ (self.a * kw).T + c @ (self.b * kw).T
        return q, qd, qdd

    def at_rest(self) -> FourierTrajectory:
        """The closest coefficients (least squares) with q(0) = q0 and qd(0) = qdd(0) = 0."""
        k = np.arange(1, self.harmonics + 1, dtype=float)
        if self.harmonics < 3:
            raise InputError("a rest-to-rest Fourier segment needs at least 3 harmonics.")
        Ca, Cb = np.ones((1, len(k))), np.vstack([1.0 / k, k])
        a = self.a - self.a @ np.linalg.pinv(Ca) @ Ca
        b = self.b - self.b @ np.linalg.pinv(Cb) @ Cb
        return replace(self, a=a, b=b)

    def scaled(self, factor: float) -> FourierTrajectory:
        """Same shape, amplitudes (and velocities, accelerations) multiplied by ``factor``."""
        return replace(self, a=factor * self.a, b=factor * self.b)


@dataclass(frozen=True)
class SegmentedTrajectory:
    """Rest-to-rest Fourier segments run one after the other, segment i for repeats[i] periods.

    After the last segment the robot rests at the last segment's q0.
    """

    segments: tuple[FourierTrajectory, ...]
    repeats: tuple[int, ...]

    def __post_init__(self):
        if len(self.segments) == 0 or len(self.segments) != len(self.repeats):
            raise InputError("give one repeat count per segment and at least one segment.")
        if any(int(r) != r or r < 1 for r in self.repeats):
            raise InputError(f"repeats must be positive integers, got {self.repeats}.")
        if len({s.q0.shape for s in self.segments}) != 1:
            raise InputError("all segments must drive the same number of joints.")

    @property
    def duration(self) -> float:
        """Total length in s."""
        return float(sum(s.period * r for s, r in zip(self.segments, self.repeats, strict=True)))

    @property
    def n_joints(self) -> int:
        return len(self.segments[0].q0)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, qd, qdd (N, n) at times t (N,) s."""
        t = np.atleast_1d(as_float_array(t, "t"))
        lengths = np.array([s.period * r for s, r in zip(self.segments, self.repeats, strict=True)])
        ends = np.cumsum(lengths)
        seg_of = np.searchsorted(ends, t, side="right")  # t in [start_i, end_i) -> i
        q = np.broadcast_to(self.segments[-1].q0, (len(t), self.n_joints)).copy()
        q[t < 0] = self.segments[0].q0
        qd, qdd = np.zeros_like(q), np.zeros_like(q)
        for i, seg in enumerate(self.segments):
            m = (seg_of == i) & (t >= 0)
            q[m], qd[m], qdd[m] = seg.evaluate(t[m] - (ends[i] - lengths[i]))
        return q, qd, qdd

    def coefficients(self) -> np.ndarray:
        """All (a, b) as one flat vector (for optimisation)."""
        return np.concatenate([np.concatenate([s.a.ravel(), s.b.ravel()]) for s in self.segments])

    def with_coefficients(self, v) -> SegmentedTrajectory:
        """The same segments with coefficients from a flat vector, projected to rest-to-rest."""
        v = as_vector(v, "coefficients", len(self.coefficients()))
        segs, i = [], 0
        for s in self.segments:
            m = s.a.size
            segs.append(replace(s, a=v[i:i + m].reshape(s.a.shape), b=v[i + m:i + 2 * m].reshape(s.b.shape)).at_rest())
            i += 2 * m
        return replace(self, segments=tuple(segs))


# -- workspace --------------------------------------------------------------------------------
def workspace_violation(robot, q: np.ndarray, margin: float = 0.0) -> float:
    """How far joint positions q (N, n) take the robot out of its workspace (0 = inside): the
    robot's own measure (:meth:`boundid.models.RobotModel.workspace_excursion`, 0 for a robot
    without a workspace; the H4: squared excursions of the poses out of its box)."""
    return robot.workspace_excursion(q, margin)


def check_in_workspace(robot, traj: SegmentedTrajectory, fs_hz: float = 100.0):
    """Raise UnreachablePoseError unless the whole trajectory (sampled at fs_hz) is in the workspace."""
    t = np.arange(0.0, traj.duration, 1.0 / fs_hz)
    out = robot.outside_workspace(traj.evaluate(t)[0])  # raises on non-convergence or singularity
    if out is not None:
        k, x = out
        raise UnreachablePoseError(
            f"trajectory leaves the workspace at t = {t[k]:.3f} s (pose {np.array2string(x, precision=3)}); "
            "scale it down with fit_to_workspace."
        )


def fit_to_workspace(robot, traj: SegmentedTrajectory, margin: float = 0.1, max_scale: float = 1.0,
                     fs_hz: float = 50.0, iters: int = 30) -> SegmentedTrajectory:
    """Scale each segment by the largest factor <= max_scale (bisection) that keeps it in the workspace.

    margin : fraction of the workspace box width kept free on every side (room for tracking error).
    """
    segs = []
    for seg in traj.segments:
        t = np.arange(0.0, seg.period, 1.0 / fs_hz)

        def bad(f, seg=seg, t=t):
            return workspace_violation(robot, seg.scaled(f).evaluate(t)[0], margin) > 0

        if not bad(max_scale):
            segs.append(seg.scaled(max_scale))
            continue
        if bad(0.0):
            raise UnreachablePoseError("the segment's rest pose q0 is outside the (shrunk) workspace.")
        lo, hi = 0.0, max_scale
        for _ in range(iters):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if bad(mid) else (mid, hi)
        segs.append(seg.scaled(lo))
    return replace(traj, segments=tuple(segs))


def exciting_trajectory(robot, rng: np.random.Generator, duration: float = 20.0, slow_fraction: float = 0.4,
                        fast_period: float = 2.0, slow_harmonics: int = 4, fast_harmonics: int = 6,
                        q0=None, margin: float = 0.1) -> SegmentedTrajectory:
    """A slow segment (friction: low speeds over the whole range) then a repeated fast one (inertia).

    duration : s, total; slow_fraction : share of the slow segment (one period);
    fast_period : s, period of the fast segment, repeated to fill the rest; q0 : rest position
    (default: the robot's ``rest_position()``, the home pose's angles for the H4); random
    coefficients from ``rng``, made rest-to-rest and scaled to stay inside the workspace shrunk by ``margin``.
    """
    if not (duration > 0 and 0 < slow_fraction < 1 and fast_period > 0):
        raise InputError("need duration > 0 s, 0 < slow_fraction < 1 and fast_period > 0 s.")
    n = robot.n_joints
    q0 = as_vector(robot.rest_position() if q0 is None else q0, "q0", n)
    slow_T = slow_fraction * duration
    reps = max(1, int(round((duration - slow_T) / fast_period)))
    segs = []
    for T, K in ((slow_T, slow_harmonics), (fast_period, fast_harmonics)):
        a, b = rng.normal(size=(n, K)), rng.normal(size=(n, K))
        segs.append(FourierTrajectory(T, q0, a, b).at_rest())
    traj = SegmentedTrajectory(tuple(segs), (1, reps))
    return fit_to_workspace(robot, traj, margin=margin, max_scale=100.0)


# -- excitation quality -----------------------------------------------------------------------
def observation_matrix(robot, traj: SegmentedTrajectory, fs_hz: float = 20.0) -> np.ndarray:
    """Stacked noise-free regressor W (N n, p) of the trajectory sampled at fs_hz (exact qd, qdd)."""
    t = np.arange(0.0, traj.duration, 1.0 / fs_hz)
    q, qd, qdd = traj.evaluate(t)
    return robot.regressor(q, qd, qdd).reshape(-1, robot.p)


def condition_number(W, scaled: bool = True) -> float:
    """2-norm condition number of W; ``scaled`` first divides each column by its norm.

    Column scaling makes the number independent of the parameters' units (kg m^2 vs N m).
    """
    W = np.asarray(W, float)
    if scaled:
        norms = np.linalg.norm(W, axis=0)
        if np.any(norms == 0):
            return float("inf")
        W = W / norms
    s = np.linalg.svd(W, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def optimize_trajectory(robot, traj: SegmentedTrajectory, fs_hz: float = 10.0, margin: float = 0.1,
                        max_evals: int = 400, scaled: bool = False, penalty: float = 1e4
                        ) -> tuple[SegmentedTrajectory, dict]:
    """Lower cond(W) over the Fourier coefficients with Powell's method (scipy.optimize).

    Objective: log10 cond(W) + penalty x workspace_violation, the workspace shrunk by margin / 2
    (the start, fitted with ``margin``, is strictly inside). ``scaled`` chooses the column-scaled
    condition number (default: the raw one, as Swevers et al.). Derivative-free (the penalty is
    not smooth), at most ``max_evals`` objective evaluations (about 10 ms each for the H4 at the
    default 10 Hz sampling). Deterministic given ``traj`` (build it with a seeded Generator). The result is
    re-fitted to the workspace with ``margin``. Returns it and the condition numbers before/after.
    """
    if max_evals < 1:
        raise InputError(f"max_evals must be >= 1, got {max_evals}.")
    t = np.arange(0.0, traj.duration, 1.0 / fs_hz)

    def objective(v):
        tr = traj.with_coefficients(v)
        q, qd, qdd = tr.evaluate(t)
        viol = workspace_violation(robot, q, 0.5 * margin)
        try:
            W = robot.regressor(q, qd, qdd).reshape(-1, robot.p)
        except UnreachablePoseError:
            return 10.0 + penalty * viol
        return np.log10(condition_number(W, scaled)) + penalty * viol

    v0 = traj.coefficients()
    f0 = objective(v0)
    res = optimize.minimize(objective, v0, method="Powell", options={"maxfev": max_evals, "xtol": 1e-3})
    best = fit_to_workspace(robot, traj.with_coefficients(res.x if res.fun < f0 else v0), margin=margin)
    return best, {
        "cond_before": condition_number(observation_matrix(robot, traj, fs_hz), scaled),
        "cond_after": condition_number(observation_matrix(robot, best, fs_hz), scaled),
        "scaled": scaled, "nfev": int(res.nfev), "message": str(res.message),
    }
