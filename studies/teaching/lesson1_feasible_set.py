# %% [markdown]
# # Lesson 1: the feasible set of bounded-error data
#
# A pendulum without friction, tau = J qdd + mgl sin q, is linear in theta = (J, mgl). Each
# measurement with a torque error bounded by |e| <= e_max allows a *strip* of parameters,
# |tau_k - w_k^T theta| <= e_max with w_k = (qdd_k, sin q_k). The feasible set is the polygon
# where all strips overlap. We draw it strip by strip, then compute its exact description
# (vertices, LP bounding box, Chebyshev centre) and its inner and outer ellipsoids (SDP).
# Every sentence of the handout is written from the numbers this script computes.

# %%
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.patches import Rectangle

from boundid.models import LinearToy
from boundid.report import PALETTE
from boundid.sets import Ellipsoid, Polytope, inner_ellipsoid, john_outer, outer_ellipsoid
from boundid.teaching import Handout, fast_mode, fmt, output_dir

FAST = fast_mode()
N = 10 if FAST else 25             # number of measurements (strips)
N_EXTRA = 5                        # further measurements, for the last exercise
E_MAX = 0.15                       # torque error bound, N m
QDD_MAX = 1.5                      # rad/s^2: slow swings, so that J and mgl are about equally well determined
rng = np.random.default_rng(1)
theta_true = LinearToy().theta_true[:2]          # (J [kg m^2], mgl [N m])
names = ("J", "mgl")
q = rng.uniform(-1.2, 1.2, N + N_EXTRA)          # rad
qdd = rng.uniform(-QDD_MAX, QDD_MAX, N + N_EXTRA)
W_all = np.column_stack([qdd, np.sin(q)])
y_all = W_all @ theta_true + rng.uniform(-E_MAX, E_MAX, N + N_EXTRA)
W, y = W_all[:N], y_all[:N]
LABELS = ("J [kg m²]", "mgl [N m]")



def square_window(center, half):
    """Equal ranges on both axes about ``center`` (with equal aspect, a disc looks like one)."""
    return center - half, center + half


# %% [markdown]
# ## The exact polygon
# HiGHS solves the LPs: per-parameter bounds (the bounding box), the Chebyshev centre (largest
# inscribed disc) and, in 2-D, the vertices.

# %%
P = Polytope(W, y, E_MAX)
box = P.bounds()
vertices = P.boundary()[:-1]   # counter-clockwise
cheb_x, cheb_r = P.chebyshev_center()
active = P.nonredundant()
view = square_window(box.center, 6.0 * box.half_width.max())   # the window of the strip pictures

# %% [markdown]
# ## Strips one by one
# Each new strip cuts the polygon of the previous ones (inside the drawing window).

# %%
steps = sorted({1, 2, 3, 5, N // 2, N})
fig = Figure(figsize=(10.0, 6.8), layout="constrained")
axes = fig.subplots(2, 3, sharex=True, sharey=True).ravel()
for ax, k in zip(axes, steps, strict=False):
    for j in range(k):
        band = Polytope(W[j:j + 1], y[j:j + 1], E_MAX, box=view)
        newest = j == k - 1
        ax.add_patch(PolygonPatch(band.boundary(), closed=True, fc="#E69F00" if newest else "#56B4E9",
                                  alpha=0.35 if newest else 0.08, ec="none"))
    Pk = Polytope(W[:k], y[:k], E_MAX, box=view)
    ax.add_patch(PolygonPatch(Pk.boundary(), closed=True, fc="none", ec="k", lw=1.8))
    ax.plot(*theta_true, "k*", ms=10)
    ax.set(xlim=(view[0][0], view[1][0]), ylim=(view[0][1], view[1][1]), aspect="equal")
    ax.set_title(f"{k} strip{'s' * (k > 1)}", fontsize=13)
for ax in axes[len(steps):]:
    ax.set_axis_off()
fig.supxlabel(LABELS[0])
fig.supylabel(LABELS[1])

# %% [markdown]
# ## Ellipsoids of the polygon (SDP, cvxpy + Clarabel)
# inner: the largest ellipse inside P; SDP outer: an ellipse around P from the S-procedure on the
# tightened strips; John: the inner ellipse scaled by p = 2 about its centre (it contains P).

# %%
ells = {"inner (max volume)": inner_ellipsoid(P).ellipsoid,
        "SDP outer": outer_ellipsoid(P).ellipsoid,
        "John (2 x inner)": john_outer(P).ellipsoid}
colors = dict(zip(ells, (PALETTE["SDP inner"], PALETTE["SDP outer"], PALETTE["SDP john"]), strict=True))  # the report's
far = np.vstack([E.boundary() for E in ells.values()] + [vertices])
zoom = square_window(box.center, 1.15 * np.abs(far - box.center).max())
fig2 = Figure(figsize=(8.6, 5.6), layout="constrained")
ax = fig2.subplots()
ax.add_patch(PolygonPatch(vertices, closed=True, fc="#cccccc", ec="k", lw=1.5, label="exact polygon P"))
ax.plot(*vertices.T, "ko", ms=3)
ax.add_patch(Rectangle(box.lo, *(box.hi - box.lo), fc="none", ec=PALETTE["LP exact"], ls="--", lw=1.2,
                       label="LP box"))
ax.plot(*Ellipsoid.ball(cheb_x, cheb_r).boundary().T, color="#CC79A7", lw=1.5, ls=":", label="Chebyshev disc")
ax.plot(*cheb_x, "+", color="#CC79A7", ms=12, mew=2, label="Chebyshev centre")
for (label, E), ls in zip(ells.items(), ("-", "--", "-."), strict=True):
    ax.plot(*E.boundary().T, color=colors[label], lw=1.8, ls=ls, label=label)
ax.plot(*theta_true, "k*", ms=12, label="truth")
ax.set(xlim=(zoom[0][0], zoom[1][0]), ylim=(zoom[0][1], zoom[1][1]), aspect="equal",
       xlabel=LABELS[0], ylabel=LABELS[1])
fig2.legend(loc="outside right upper", fontsize=10)

# %%
area_P = P.volume()
sets = {"polygon P (exact)": (area_P, True),
        "LP bounding box": (float(np.prod(box.hi - box.lo)), True),
        "Chebyshev disc": (np.pi * cheb_r**2, False)}
sets.update({label: (E.volume(), label != "inner (max volume)") for label, E in ells.items()})
truth_in = {"polygon P (exact)": bool(P.contains(theta_true)),
            "LP bounding box": bool(np.all((box.lo <= theta_true) & (theta_true <= box.hi))),
            "Chebyshev disc": bool(np.linalg.norm(theta_true - cheb_x) <= cheb_r)}
truth_in.update({label: bool(E.contains(theta_true)) for label, E in ells.items()})
contains_P = {"polygon P (exact)": True,
              "LP bounding box": bool(np.all((box.lo - 1e-9 <= vertices) & (vertices <= box.hi + 1e-9))),
              "Chebyshev disc": bool(np.all(np.linalg.norm(vertices - cheb_x, axis=1) <= cheb_r * (1 + 1e-9)))}
contains_P.update({label: bool(np.all(E.contains(vertices))) for label, E in ells.items()})
volumes = pd.DataFrame({"area": [v for v, _ in sets.values()],
                        "area / area(P)": [v / area_P for v, _ in sets.values()],
                        "contains P": list(contains_P.values()),
                        "contains truth": list(truth_in.values())},
                       index=pd.Index(list(sets), name="set"))
print(volumes)
vert_df = pd.DataFrame(vertices, columns=list(names), index=pd.Index(range(1, len(vertices) + 1), name="vertex"))
bounds_df = pd.DataFrame({"LP lo": box.lo, "LP hi": box.hi, "truth": theta_true, "Chebyshev centre": cheb_x},
                         index=pd.Index(names, name="parameter"))

# %% [markdown]
# ## Numbers for the exercises
# The Chebyshev centre depends on the units of the parameters: measure J in units of 0.1 kg m²
# (its column of W divided by 10) and compute it again. And a few more strips: does each one cut
# the polygon?

# %%
scale = np.array([10.0, 1.0])                    # J' = 10 J: J in units of 0.1 kg m^2
cheb_scaled = Polytope(W / scale, y, E_MAX).chebyshev_center()[0] / scale
cheb_shift = np.abs(cheb_scaled - cheb_x) / (box.hi - box.lo)
extra_rows = []
for k in range(N, N + N_EXTRA):
    before, after = Polytope(W_all[:k], y_all[:k], E_MAX), Polytope(W_all[:k + 1], y_all[:k + 1], E_MAX)
    extra_rows.append({"strip": k + 1, "vertices before": len(before.vertices()),
                       "vertices after": len(after.vertices()),
                       "area after / before": after.volume() / before.volume()})
extra = pd.DataFrame(extra_rows).set_index("strip")
n_cut = int((extra["area after / before"] < 1 - 1e-9).sum())
n_fewer = int((extra["vertices after"] < extra["vertices before"]).sum())

# %% [markdown]
# ## Handout: every sentence from the numbers above

# %%
r = volumes["area / area(P)"]
outer_sets = [s for s in sets if sets[s][1] and s != "polygon P (exact)"]
rel = (box.hi - box.lo) / 2 / np.abs(theta_true)
sdp_vs_box = "smaller" if r["SDP outer"] < r["LP bounding box"] else "larger"
all_contain = all(volumes.loc[s, "contains P"] for s in outer_sets)
page = Handout("Lesson 1: the feasible set",
               "A pendulum without friction, tau = J qdd + mgl sin q, is linear in theta = (J, mgl). A torque "
               "measured with an error bounded by e_max allows a strip of parameters; the feasible set is where all "
               "strips overlap. We build it strip by strip, then describe it exactly (vertices, LP box, Chebyshev "
               "centre) and by ellipses (maximum-volume inner, SDP outer, John).",
               setup={"model": "tau = J qdd + mgl sin q", "strips": N,
                      "error bound": f"{E_MAX} N m (uniform noise)",
                      "excitation": f"q uniform in ±1.2 rad, qdd uniform in ±{QDD_MAX} rad/s²",
                      "truth": f"J = {fmt(theta_true[0], 4)} kg m², mgl = {fmt(theta_true[1], 4)} N m"})
page.key_points([
    f"{N} strips leave a polygon with {len(vertices)} vertices; {len(active)} of the {N} strips touch it, "
    f"the other {N - len(active)} are redundant.",
    f"The truth {'lies inside' if truth_in['polygon P (exact)'] else 'lies OUTSIDE'} the polygon"
    + (", as it must when every error is within its bound." if truth_in["polygon P (exact)"] else
       ": some error exceeded its bound."),
    f"Exact bounds (LP): J in [{fmt(box.lo[0], 4)}, {fmt(box.hi[0], 4)}] kg m² (±{rel[0]:.1%}), "
    f"mgl in [{fmt(box.lo[1], 4)}, {fmt(box.hi[1], 4)}] N m (±{rel[1]:.1%}).",
    ("The sets built to contain the polygon do contain it and are larger: " if all_contain else
     "NOT every set built to contain the polygon contains it (see the areas table): ")
    + ", ".join(f"{s} {r[s]:.2f}x" for s in outer_sets)
    + f" its area. The largest inscribed ellipse covers {r['inner (max volume)']:.0%} of it, the Chebyshev disc "
    f"{r['Chebyshev disc']:.0%}.",
])
page.section("Strips one by one",
             "Every measurement allows a strip of parameters whose width is 2 e_max / |w_k| across it. "
             "The feasible set (black outline) is what all strips share; it only shrinks as strips arrive, "
             f"and here it {'contains' if truth_in['polygon P (exact)'] else 'misses'} the truth (star). Both axes "
             "have the same scale, so the strips' widths and angles are true to the data.")
page.figure(fig, "The strips of the first k measurements (blue; the k-th in orange) and their intersection (black "
                 "outline); star: truth.",
            name="strips")
page.section("The exact polygon and its ellipses",
             f"The polygon has {len(vertices)} vertices; {len(active)} of the {N} strips touch it (the others are "
             f"redundant). The LP box gives exact per-parameter bounds, but its area is {r['LP bounding box']:.2f}x "
             "that of P. The Chebyshev centre is the centre of the largest inscribed disc; the disc is round here "
             "because both axes have the same scale, and it would change with the units (see the exercises). The "
             f"maximum-volume inner ellipse lies inside P; the SDP outer ellipse ({r['SDP outer']:.2f}x the area of P, "
             f"{sdp_vs_box} than the LP box here) and John's ellipse ({r['John (2 x inner)']:.2f}x) contain it"
             + ("." if all_contain else ", though one of them misses a vertex: see the table."))
page.figure(fig2, "The exact polygon, its LP bounding box, Chebyshev disc and centre, inner, SDP outer and John "
                  "ellipses (equal axis scales).", name="polygon")
page.table(volumes, "Areas (kg m² · N m) of the sets, their ratio to the exact polygon, and whether each contains "
                    "every vertex of P and the truth.", name="areas")
page.table(vert_df, "Vertices of the exact polygon (counter-clockwise).", name="vertices")
page.table(bounds_df, "Exact parameter bounds (LP), truth and Chebyshev centre.", name="bounds")
page.table(extra, f"{N_EXTRA} further measurements added one at a time: vertices and area of the polygon before "
                  "and after each (for exercise 3).", name="extra-strips")

john_ratio = r["John (2 x inner)"] / r["inner (max volume)"]
by_area = volumes.sort_values("area")
order_text = ", ".join(f"{s} ({r[s]:.3g})" for s in by_area.index)
page.exercises([
    ("John's theorem says the inner ellipse scaled by p about its centre contains P. In 2-D, what area ratio "
     "John / inner follows? Check it against the areas table.",
     f"Scaling a 2-D set by p = 2 multiplies its area by p² = 4. The table gives John / inner = "
     f"{r['John (2 x inner)']:.4g} / {r['inner (max volume)']:.4g} = {john_ratio:.4g}."),
    ("Order the sets of the areas table by area. Which ones must be larger than P, which smaller, and why is the "
     "SDP outer ellipse not necessarily smaller than the LP box?",
     f"By area / area(P): {order_text}. The inner ellipse and the Chebyshev disc lie inside P, so they are smaller; "
     "the LP box, the SDP outer and John's ellipses contain P, so they are larger. The box and the ellipses are "
     "different shapes fitted by different rules (the box is exact per axis, the SDP ellipse is an upper bound on "
     f"the smallest enclosing ellipse): here the SDP outer ellipse is {sdp_vs_box} than the box "
     f"({r['SDP outer']:.3g} against {r['LP bounding box']:.3g})."),
    ("Add the further measurements of the last table one at a time. Does every new strip cut the polygon, and "
     "does a cut always remove a vertex?",
     f"{n_cut} of the {N_EXTRA} new strips reduced the area; the other {N_EXTRA - n_cut} were redundant (area "
     f"ratio 1). {n_fewer} of them lowered the vertex count: a strip that cuts off a corner replaces one vertex "
     "by two, so a cut can add vertices as well as remove them."),
    ("Measure J in units of 0.1 kg m² (divide its column of W by 10) and compute the Chebyshev centre again. Does "
     "it move? Do the LP bounds change?",
     f"In the original units the centre is ({fmt(cheb_x[0], 4)}, {fmt(cheb_x[1], 4)}); with J in 0.1 kg m² it is "
     f"({fmt(cheb_scaled[0], 4)}, {fmt(cheb_scaled[1], 4)}) back in kg m², a shift of {cheb_shift[0]:.1%} and "
     f"{cheb_shift[1]:.1%} of the LP box widths. The largest inscribed disc depends on how the axes are scaled; "
     "the LP bounds and the polygon itself only change units."),
])
print(page.write(output_dir("lesson1_feasible_set") / "index.html"))
