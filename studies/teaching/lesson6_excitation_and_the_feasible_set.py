# %% [markdown]
# # Lesson 6: excitation and the feasible set
#
# The classical excitation criteria look only at W^T W: its condition number, or log det W^T W.
# Two trajectories with the *same* W^T W therefore score the same. The exact feasible set of
# bounded-error data, the polygon where all strips |y_k - w_k^T theta| <= e_max overlap, does not
# depend on W^T W alone: it depends on the directions and lengths of the rows w_k one by one. We take
# the pendulum of lesson 1, tau = J qdd + mgl sin q with theta = (J, mgl), and two trajectories:
# A, whose rows w_k = (qdd_k, sin q_k) point in many directions, and B, built to have exactly the same
# W^T W with its rows in only two (orthogonal) directions. Same condition number, different sets.
# Every sentence of the handout is written from the numbers this script computes.

# %%
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch

from boundid.models import LinearToy
from boundid.report import PALETTE
from boundid.sets import Polytope
from boundid.teaching import Handout, fast_mode, fmt, output_dir

FAST = fast_mode()
N = 12 if FAST else 24             # measurements (strips) of each trajectory
N_DRAWS = 20 if FAST else 200      # noise draws for the "with noise" comparison
E_MAX = 0.15                       # torque error bound, N m
QDD_MAX = 1.5                      # rad/s^2, as in lesson 1
COND_TOL = 1e-9                    # relative tolerance of "the same condition number"
rng = np.random.default_rng(1)
theta_true = LinearToy().theta_true[:2]          # (J [kg m^2], mgl [N m])
names = ("J", "mgl")
LABELS = ("J [kg m²]", "mgl [N m]")
COLORS = {"A": "#0072B2", "B": "#D55E00"}        # the report's first series colours (Okabe-Ito)

# Trajectory A: random slow swings, as in lesson 1; the rows point in many directions.
q_A = rng.uniform(-1.2, 1.2, N)
qdd_A = rng.uniform(-QDD_MAX, QDD_MAX, N)
W_A = np.column_stack([qdd_A, np.sin(q_A)])

# Trajectory B, by design: W_B = Q diag(sqrt(lambda)) V^T with W_A^T W_A = V diag(lambda) V^T and Q
# (N x 2) with orthonormal columns whose rows are +-1/sqrt(N/2) on one column only. Then
# W_B^T W_B = W_A^T W_A exactly, and every row of W_B is +-sqrt(2 lambda_i / N) v_i: two directions.
G = W_A.T @ W_A
lam, V = np.linalg.eigh(G)
half = N // 2
Q = np.zeros((N, 2))
Q[:half, 0] = 1.0 / np.sqrt(half)
Q[half:, 1] = 1.0 / np.sqrt(N - half)
Q *= np.where(np.arange(N) % 2 == 0, 1.0, -1.0)[:, None]      # alternate the swing direction
Q = Q[np.argsort(np.arange(N) % half, kind="stable")]         # interleave the two directions in time
W_B = Q @ np.diag(np.sqrt(lam)) @ V.T
assert np.abs(W_B[:, 1]).max() < 1.0, "B must be a pendulum trajectory: |sin q| <= 1"
qdd_B, q_B = W_B[:, 0], np.arcsin(W_B[:, 1])                   # the trajectory that gives these rows
TRAJ = {"A": W_A, "B": W_B}



def n_directions(W, tol=1e-6):
    """Number of distinct strip directions (row angles modulo pi)."""
    ang = np.sort(np.mod(np.arctan2(W[:, 1], W[:, 0]), np.pi))
    gaps = np.diff(np.r_[ang, ang[0] + np.pi])
    return int(max(1, (gaps > tol).sum()))


def normalised(W):
    """W with unit-norm columns (the usual scaling before a condition number)."""
    return W / np.linalg.norm(W, axis=0)


# %% [markdown]
# ## The classical criteria
# cond(W), cond(W) after scaling its columns to unit norm, and log det W^T W. All three depend on
# W^T W only, which is the same for A and B by construction.

# %%
crit = pd.DataFrame({"rows": [len(W) for W in TRAJ.values()],
                     "strip directions": [n_directions(W) for W in TRAJ.values()],
                     "cond(W)": [np.linalg.cond(W) for W in TRAJ.values()],
                     "cond(W, unit columns)": [np.linalg.cond(normalised(W)) for W in TRAJ.values()],
                     "log det W^T W": [np.linalg.slogdet(W.T @ W)[1] for W in TRAJ.values()],
                     "max |w_k|": [np.linalg.norm(W, axis=1).max() for W in TRAJ.values()],
                     "max |q| [rad]": [np.abs(q_A).max(), np.abs(q_B).max()],
                     "max |qdd| [rad/s²]": [np.abs(qdd_A).max(), np.abs(qdd_B).max()]},
                    index=pd.Index(["A", "B"], name="trajectory"))
cond_gap = float(np.abs(crit["cond(W)"].iloc[1] / crit["cond(W)"].iloc[0] - 1))
cond_gap_n = float(np.abs(crit["cond(W, unit columns)"].iloc[1] / crit["cond(W, unit columns)"].iloc[0] - 1))
same_cond = max(cond_gap, cond_gap_n) <= COND_TOL
print(crit)

# %% [markdown]
# ## The exact sets
# With every error equal to zero, y = W theta_true, the feasible set is theta_true + {d : |W d| <= e_max}:
# a polygon fixed by the trajectory alone (the design set). For any admissible errors the feasible set
# lies inside theta_true + 2 {d : |W d| <= e_max}, so the design set measures what the trajectory can
# guarantee. HiGHS gives the LP bounds, the vertices give the area.

# %%
exact = {}
for name, W in TRAJ.items():
    P = Polytope(W, W @ theta_true, E_MAX)
    box = P.bounds()
    verts = P.boundary()[:-1]   # counter-clockwise
    x, yv = verts.T
    area = 0.5 * abs(np.dot(x, np.roll(yv, -1)) - np.dot(yv, np.roll(x, -1)))     # shoelace, from the vertices
    exact[name] = {"P": P, "box": box, "vertices": verts, "area": area}
sets = pd.DataFrame({"cond(W)": crit["cond(W)"],
                     "J width": [exact[t]["box"].hi[0] - exact[t]["box"].lo[0] for t in TRAJ],
                     "mgl width": [exact[t]["box"].hi[1] - exact[t]["box"].lo[1] for t in TRAJ],
                     "vertices": [len(exact[t]["vertices"]) for t in TRAJ],
                     "area": [exact[t]["area"] for t in TRAJ],
                     "area (Polytope.volume)": [exact[t]["P"].volume() for t in TRAJ]},
                    index=pd.Index(["A", "B"], name="trajectory"))
area_ratio = sets.loc["B", "area"] / sets.loc["A", "area"]
width_ratio = (sets.loc["B", ["J width", "mgl width"]] / sets.loc["A", ["J width", "mgl width"]]).to_numpy()
print(sets)

# %% [markdown]
# ## Strips one by one, A and B side by side
# The same axes in every frame; the strips are centred on the truth (zero errors).

# %%
far = np.vstack([exact[t]["vertices"] for t in TRAJ])
reach = 1.6 * np.abs(far - theta_true).max()
view = (theta_true - reach, theta_true + reach)
steps = sorted({1, 2, 3, 4, half, N})
frames, frame_labels = [], []
for k in steps:
    fig = Figure(figsize=(10.0, 4.8), layout="constrained")
    axes = fig.subplots(1, 2, sharex=True, sharey=True)
    for ax, (name, W) in zip(axes, TRAJ.items(), strict=True):
        y0 = W @ theta_true
        for j in range(k):
            band = Polytope(W[j:j + 1], y0[j:j + 1], E_MAX, box=view)
            newest = j == k - 1
            ax.add_patch(PolygonPatch(band.boundary(), closed=True, fc="#E69F00" if newest else "#56B4E9",
                                      alpha=0.35 if newest else 0.10, ec="none"))
        Pk = Polytope(W[:k], y0[:k], E_MAX, box=view)
        ax.add_patch(PolygonPatch(Pk.boundary(), closed=True, fc="none", ec=COLORS[name], lw=2.0))
        ax.plot(*theta_true, "*", color=PALETTE["truth"], ms=10)
        ax.set(xlim=(view[0][0], view[1][0]), ylim=(view[0][1], view[1][1]), aspect="equal", xlabel=LABELS[0])
        ax.set_title(f"trajectory {name}: {k} strip{'s' * (k > 1)}, area {fmt(Pk.volume(), 3)}", fontsize=12)
    axes[0].set_ylabel(LABELS[1])
    frames.append(fig)
    frame_labels.append(f"{k} of {N} strips")

# %% [markdown]
# ## The two final polygons, overlaid

# %%
fig2 = Figure(figsize=(8.6, 5.6), layout="constrained")
ax = fig2.subplots()
for name, ls in zip(TRAJ, ("-", "--"), strict=True):
    v = exact[name]["vertices"]
    ax.add_patch(PolygonPatch(v, closed=True, fc=COLORS[name], alpha=0.12, ec="none"))
    ax.add_patch(PolygonPatch(v, closed=True, fc="none", ec=COLORS[name], lw=2.0, ls=ls,
                              label=f"{name}: exact set, area {fmt(exact[name]['area'], 3)}"))
    b = exact[name]["box"]
    ax.plot([b.lo[0], b.hi[0], b.hi[0], b.lo[0], b.lo[0]], [b.lo[1], b.lo[1], b.hi[1], b.hi[1], b.lo[1]],
            color=COLORS[name], lw=1.0, ls=":", label=f"{name}: LP box")
ax.plot(*theta_true, "*", color=PALETTE["truth"], ms=12, label="truth")
zoom = 1.15 * np.abs(far - theta_true).max()
ax.set(xlim=(theta_true[0] - zoom, theta_true[0] + zoom), ylim=(theta_true[1] - zoom, theta_true[1] + zoom),
       aspect="equal", xlabel=LABELS[0], ylabel=LABELS[1])
fig2.legend(loc="outside right upper", fontsize=10)

# %% [markdown]
# ## Numbers for the exercises
# With real (uniform) errors the strips no longer all pass through the truth. The same error draws
# are applied to A and B; and how the area of B's design set grows with the number of samples when
# W^T W is kept fixed.

# %%
areas = np.empty((N_DRAWS, 2))
for d in range(N_DRAWS):
    err = rng.uniform(-E_MAX, E_MAX, N)
    for j, W in enumerate(TRAJ.values()):
        areas[d, j] = Polytope(W, W @ theta_true + err, E_MAX).volume()
noisy = pd.DataFrame({"median area": np.median(areas, axis=0), "mean area": areas.mean(axis=0),
                      "design-set area": sets["area"].to_numpy()},
                     index=pd.Index(["A", "B"], name="trajectory"))
noisy_ratio = noisy.loc["B", "median area"] / noisy.loc["A", "median area"]
b_larger = float((areas[:, 1] > areas[:, 0]).mean())
grow_rows = []
for n in (2, 4, 8, 16, 32):
    Qn = np.zeros((2 * n, 2))
    Qn[:n, 0], Qn[n:, 1] = 1.0 / np.sqrt(n), 1.0 / np.sqrt(n)
    Wn = Qn @ np.diag(np.sqrt(lam)) @ V.T
    grow_rows.append({"rows": 2 * n, "cond(W)": np.linalg.cond(Wn),
                      "design-set area": Polytope(Wn, Wn @ theta_true, E_MAX).volume(),
                      "4 e_max² sqrt(n² / det W^T W)": 4 * E_MAX**2 * n / np.sqrt(np.prod(lam))})
grow = pd.DataFrame(grow_rows).set_index("rows")
print(noisy, grow, sep="\n")

# %% [markdown]
# ## Handout: every sentence from the numbers above

# %%
bigger = "larger" if area_ratio > 1 else "smaller"
page = Handout("Lesson 6: excitation and the feasible set",
               "The classical excitation criteria (condition number of W, log det W^T W) depend on W^T W only. The "
               "exact feasible set of bounded-error data depends on every row of W. Two pendulum trajectories with "
               "the same W^T W, one whose strips point in many directions (A) and one whose strips point in only two "
               "(B), give the same condition number and different exact sets.",
               setup={"model": "tau = J qdd + mgl sin q", "strips per trajectory": N,
                      "error bound": f"{E_MAX} N m",
                      "trajectory A": f"q uniform in ±1.2 rad, qdd uniform in ±{QDD_MAX} rad/s²",
                      "trajectory B": "W_B = Q diag(sqrt(lambda)) V^T: same W^T W, rows along the two eigenvectors",
                      "noise draws (exercise)": N_DRAWS,
                      "truth": f"J = {fmt(theta_true[0], 4)} kg m², mgl = {fmt(theta_true[1], 4)} N m"})
page.key_points([
    f"Same classical score: cond(W) = {crit.loc['A', 'cond(W)']:.6f} for A and {crit.loc['B', 'cond(W)']:.6f} for B "
    f"(relative gap {cond_gap:.1e}; {cond_gap_n:.1e} after scaling the columns to unit norm), log det W^T W = "
    f"{crit.loc['A', 'log det W^T W']:.4f} and {crit.loc['B', 'log det W^T W']:.4f}"
    + (f": equal to within {COND_TOL:.0e}." if same_cond else f": NOT equal to within {COND_TOL:.0e}."),
    f"A's {N} strips point in {crit.loc['A', 'strip directions']} directions, B's in "
    f"{crit.loc['B', 'strip directions']}.",
    f"Different exact sets: with zero errors, B's feasible polygon has area {fmt(sets.loc['B', 'area'], 3)} against "
    f"{fmt(sets.loc['A', 'area'], 3)} for A ({fmt(area_ratio)}x, {bigger}), and LP widths {fmt(width_ratio[0])}x (J) "
    f"and {fmt(width_ratio[1])}x (mgl) those of A.",
    f"With uniform errors (the same {N_DRAWS} draws for both) the median area of B is {fmt(noisy_ratio)}x that of A; "
    f"B's polygon is the larger in {b_larger:.0%} of the draws.",
])
page.section("Same W^T W by construction",
             f"B is built from A: with W_A^T W_A = V diag(lambda) V^T, W_B = Q diag(sqrt(lambda)) V^T where Q has "
             f"orthonormal columns and each of its rows is ±1/sqrt({half}) on one column. Then W_B^T W_B = W_A^T W_A, "
             f"so every criterion computed from W^T W is the same. B is a real pendulum trajectory: |q| up to "
             f"{crit.loc['B', 'max |q| [rad]']:.2f} rad and |qdd| up to {crit.loc['B', 'max |qdd| [rad/s²]']:.2f} "
             f"rad/s² (A: {crit.loc['A', 'max |q| [rad]']:.2f} rad, {crit.loc['A', 'max |qdd| [rad/s²]']:.2f} rad/s²).")
page.table(crit, "The classical criteria and the trajectories' ranges.", name="criteria")
page.section("Strips one by one",
             "A strip has width 2 e_max / |w_k| across it. B spreads the same energy evenly over its rows, so each "
             f"of its strips is wide (longest row {crit.loc['B', 'max |w_k|']:.3f} against "
             f"{crit.loc['A', 'max |w_k|']:.3f} for A), and strips of the same direction with zero errors coincide: "
             f"after the first strip of each direction the later ones cut nothing. A's strips come from "
             f"{crit.loc['A', 'strip directions']} directions and its longest rows cut the polygon down.")
page.stepper(frames, frame_labels, "The strips of the first k measurements (blue; the k-th in orange) and their "
                                   "intersection (outline), for A (left) and B (right), zero errors; star: truth.",
             name="strips")
page.section("Same condition number, different exact sets",
             f"B's polygon is {fmt(area_ratio)}x the area of A's. W^T W sums the squares of the rows; the exact set "
             "is bounded by the longest rows in each direction, which the sum does not see.")
page.figure(fig2, "The exact design sets of A and B (zero errors) with their LP boxes (equal axis scales).",
            name="polygons")
page.table(sets, "cond(W), exact LP widths, vertices and areas (shoelace formula from P.vertices(), and "
                 "Polytope.volume) of the design sets.", name="sets")
page.table(noisy, f"Areas of the exact sets with uniform errors ({N_DRAWS} draws, the same for A and B), and the "
                  "design-set areas (for exercise 1).", name="noisy")
page.table(grow, "B-type trajectories (two directions, n rows each) with W^T W fixed to that of A: design-set area "
                 "against the number of rows (for exercise 2).", name="growth")

g = grow["design-set area"]
page.exercises([
    ("With real errors the strips no longer pass through the truth. Does B's polygon stay larger than A's? Use "
     "the table of noisy areas, and explain why repeated strips of one direction can still help.",
     f"Median area with errors: A {fmt(noisy.loc['A', 'median area'], 3)}, B {fmt(noisy.loc['B', 'median area'], 3)} "
     f"(B/A = {fmt(noisy_ratio)}, against {fmt(area_ratio)} with zero errors); B is the larger in {b_larger:.0%} "
     "of the draws. Parallel strips with different errors are shifted against each other, so their "
     "intersection is narrower than one strip: repeats help B only through the luck of the errors, while the "
     "design set is what the trajectory guarantees (any feasible set lies within twice it about the truth)."),
    ("Keep W^T W fixed and spread it over more rows of B (two directions, n rows each). How does the area of the "
     "design set grow with n, and what does cond(W) say?",
     f"Each row has length sqrt(lambda_i / n), so each strip is sqrt(n) times wider and the rectangle's area "
     f"grows like n: {', '.join(f'{r} rows {fmt(v, 3)}' for r, v in g.items())}, matching "
     f"4 e_max² n / sqrt(det W^T W). cond(W) stays {grow['cond(W)'].iloc[0]:.6f} for every n (range "
     f"{grow['cond(W)'].max() - grow['cond(W)'].min():.1e}): it cannot see this."),
])
print(page.write(output_dir("lesson6_excitation_and_the_feasible_set") / "index.html"))
