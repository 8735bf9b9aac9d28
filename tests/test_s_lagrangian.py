"""The S-procedure solved in its multipliers (boundid.sets._s_lagrangian), against finite differences
and against Clarabel's solve of the same strips (boundid.sets.sdp._s_procedure), a second algorithm."""

import numpy as np
import pytest

from boundid.errors import SolverError
from boundid.sets._s_lagrangian import lagrangian_derivatives, lagrangian_parts, s_procedure_multipliers
from boundid.sets.sdp import _certified, _outer_multipliers, _reduced_costs, _s_procedure


def strips(n: int, m: int, seed: int):
    """The box |z_j| <= 1 and m random unit strips through it."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(m, n))
    G /= np.linalg.norm(G, axis=1)[:, None]
    return (np.vstack([np.eye(n), G]), np.concatenate([np.zeros(n), rng.uniform(-0.2, 0.2, m)]),
            np.concatenate([np.ones(n), rng.uniform(0.3, 1.5, m)]))


def f(G, mid, half, tau):
    """The Lagrangian ln det A + n s of the module docstring."""
    A = (G.T * tau) @ G
    return np.linalg.slogdet(A)[1] + G.shape[1] * lagrangian_parts(G, mid, half, tau)[2]


def ellipsoid(G, mid, half, tau):
    """(ln det A / r^2, centre) of the ellipsoid of the multipliers tau."""
    A = (G.T * tau) @ G
    b = -(G.T @ (mid * tau))
    r2 = b @ np.linalg.solve(A, b) - tau @ (mid**2 - half**2)
    return np.linalg.slogdet(A / r2)[1], -np.linalg.solve(A, b)


def test_derivatives_match_finite_differences():
    """The solver's gradient and Hessian (lagrangian_derivatives) against central differences of f
    and of that gradient."""
    G, mid, half = strips(4, 12, 0)
    tau = np.random.default_rng(1).uniform(0.05, 0.2, G.shape[0])
    grad, neg_hess, _ = lagrangian_derivatives(G, mid, half, tau)
    h = 1e-6
    for k in (0, 5, 11):
        e = np.zeros_like(tau)
        e[k] = h
        assert (f(G, mid, half, tau + e) - f(G, mid, half, tau - e)) / (2 * h) == pytest.approx(grad[k], rel=1e-6)
        up, down = lagrangian_derivatives(G, mid, half, tau + e)[0], lagrangian_derivatives(G, mid, half, tau - e)[0]
        fd = (up - down) / (2 * h)
        np.testing.assert_allclose(-fd, neg_hess[:, k], rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("n, m, seed", [(2, 6, 0), (5, 30, 1), (12, 120, 2)])
def test_optimum_matches_clarabel(n, m, seed):
    G, mid, half = strips(n, m, seed)
    tau, steps = s_procedure_multipliers(G, mid, half)
    ours, centre = ellipsoid(G, mid, half, tau)
    A0, b0 = _s_procedure(G, mid, half, [], False, "test", study_scale=True)[:2]
    theirs = np.linalg.slogdet(A0)[1]
    # the same optimum to Clarabel's tolerance, and never a worse one (ln det A is maximised)
    assert ours == pytest.approx(theirs, abs=1e-5 * (1 + abs(theirs)))
    assert ours >= theirs - 1e-7 * (1 + abs(theirs))
    np.testing.assert_allclose(centre, -np.linalg.solve(A0, b0), atol=1e-4)
    assert steps < 40
    # the pseudo-moments the caller prices with, against Clarabel's dual, on every strip
    Zd = _outer_multipliers(G, mid, half, False)[-1]
    Zc = _s_procedure(G, mid, half, [], False, "test", study_scale=True)[-1]
    ours_rc, theirs_rc = (_reduced_costs(Z, G, mid - half, mid + half)[0] for Z in (Zd, Zc))
    np.testing.assert_allclose(ours_rc, theirs_rc, atol=1e-4 * (1 + np.abs(theirs_rc).max()))


def test_answer_is_a_certified_optimum():
    G, mid, half = strips(6, 40, 3)
    n = G.shape[1]
    tau, _ = s_procedure_multipliers(G, mid, half)
    A = (G.T * tau) @ G
    b = -(G.T @ (mid * tau))
    r2 = b @ np.linalg.solve(A, b) - tau @ (mid**2 - half**2)
    assert r2 == pytest.approx(1.0, abs=1e-7)
    # the certificate holds for these multipliers: no enlargement needed
    _, _, residual = _certified(A / r2, b / r2, G, mid, half, tau / r2, [], np.zeros(0), float(n), "test")
    assert residual < 1e-10
    # KKT through the pricing the caller uses: no strip has a positive reduced cost, and the strips
    # that carry a multiplier price at zero (complementary slackness)
    centre = -np.linalg.solve(A, b)
    Zd = np.block([[np.linalg.inv(A / r2) / n + np.outer(centre, centre), centre[:, None]],
                   [centre[None, :], np.ones((1, 1))]])
    rc = _reduced_costs(Zd, G, mid - half, mid + half)[0]
    assert rc.max() < 1e-7
    on = tau > 1e-6 * tau.max()
    assert np.abs(rc[on]).max() < 1e-6
    assert on.sum() < G.shape[0]          # some strips are redundant for the S-procedure


def test_disjoint_strips_are_refused():
    G = np.array([[1.0], [1.0]])
    with pytest.raises(SolverError, match="interior"):
        s_procedure_multipliers(G, np.array([0.0, 3.0]), np.array([1.0, 1.0]))
