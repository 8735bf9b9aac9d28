# %% [markdown]
# # Lesson 1: the feasible set of bounded-error data
#
# A pendulum without friction, tau = J qdd + mgl sin q, is linear in theta = (J, mgl). Each
# measurement with a torque error bounded by |e| <= e_max allows a *strip* of parameters,
# |tau_k - w_k^T theta| <= e_max with w_k = (qdd_k, sin q_k). The feasible set is the polygon
# where all strips overlap. We draw it strip by strip, then compute its exact description
# (vertices, LP bounding box, Chebyshev centre) and its inner and outer ellipsoids (SDP).

# %%
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.patches import Rectangle

from boundid.models import LinearToy
from boundid.report import color_for
from boundid.sets import Ellipsoid, Polytope, inner_ellipsoid, john_outer, outer_ellipsoid
from boundid.teaching import Handout, fast_mode, output_dir

FAST = fast_mode()
N = 10 if FAST else 25             # number of measurements (strips)
E_MAX = 0.15                       # torque error bound, N m
rng = np.random.default_rng(1)
theta_true = LinearToy().theta_true[:2]          # (J [kg m^2], mgl [N m])
names = ("J", "mgl")
q = rng.uniform(-1.2, 1.2, N)                    # rad
qdd = rng.uniform(-8.0, 8.0, N)                  # rad/s^2
W = np.column_stack([qdd, np.sin(q)])
y = W @ theta_true + rng.uniform(-E_MAX, E_MAX, N)


def ordered(vertices):
    """Vertices of a convex polygon in counter-clockwise order (for drawing)."""
    c = vertices.mean(axis=0)
    return vertices[np.argsort(np.arctan2(vertices[:, 1] - c[1], vertices[:, 0] - c[0]))]


# %% [markdown]
# ## The exact polygon
# HiGHS solves the LPs: per-parameter bounds (the bounding box), the Chebyshev centre (largest
# inscribed disc) and, in 2-D, the vertices.

# %%
P = Polytope(W, y, E_MAX)
box = P.bounds()
vertices = ordered(P.vertices())
cheb_x, cheb_r = P.chebyshev_center()
active = P.nonredundant()
half = 8.0 * box.half_width
view = (box.center - half, box.center + half)    # the window we draw in

# %% [markdown]
# ## Strips one by one
# Each new strip cuts the polygon of the previous ones (inside the drawing window).

# %%
steps = sorted({1, 2, 3, 5, N // 2, N})
fig = Figure(figsize=(9.6, 6.0), layout="constrained")
axes = fig.subplots(2, 3).ravel()
for ax, k in zip(axes, steps, strict=False):
    for j in range(k):
        band = Polytope(W[j:j + 1], y[j:j + 1], E_MAX, box=view)
        ax.add_patch(PolygonPatch(ordered(band.vertices()), closed=True, fc="#56B4E9", alpha=0.12,
                                  ec="#56B4E9", lw=0.6))
    Pk = Polytope(W[:k], y[:k], E_MAX, box=view)
    ax.add_patch(PolygonPatch(ordered(Pk.vertices()), closed=True, fc="none", ec="k", lw=1.5))
    ax.plot(*theta_true, "k*", ms=8)
    ax.set(xlim=(view[0][0], view[1][0]), ylim=(view[0][1], view[1][1]), title=f"{k} strip{'s' * (k > 1)}",
           xlabel="J [kg m²]", ylabel="mgl [N m]")
for ax in axes[len(steps):]:
    ax.set_axis_off()

# %% [markdown]
# ## Ellipsoids of the polygon (SDP, cvxpy + Clarabel)
# inner: the largest ellipse inside P; SDP outer: an ellipse around P from the S-procedure on the
# tightened strips; John: the inner ellipse scaled by p = 2 about its centre (it contains P).

# %%
ells = {"inner (max volume)": inner_ellipsoid(P).ellipsoid,
        "SDP outer": outer_ellipsoid(P).ellipsoid,
        "John (2 x inner)": john_outer(P).ellipsoid}
fig2 = Figure(figsize=(6.4, 4.8), layout="constrained")
ax = fig2.subplots()
ax.add_patch(PolygonPatch(vertices, closed=True, fc="#cccccc", ec="k", lw=1.5, label="exact polygon P"))
ax.plot(*vertices.T, "ko", ms=3)
ax.add_patch(Rectangle(box.lo, *(box.hi - box.lo), fc="none", ec=color_for("LP exact"), ls="--", label="LP box"))
ax.plot(*Ellipsoid.ball(cheb_x, cheb_r).boundary().T, color="#AA4499", lw=1, label="Chebyshev disc")
ax.plot(*cheb_x, "+", color="#AA4499", ms=10)
for label, E in ells.items():
    ax.plot(*E.boundary().T, color=color_for(label), lw=1.5, label=label)
ax.plot(*theta_true, "k*", ms=10, label="truth")
pad = 1.3 * np.max(np.abs(ells["John (2 x inner)"].boundary() - box.center), axis=0)
ax.set(xlim=(box.center[0] - pad[0], box.center[0] + pad[0]), ylim=(box.center[1] - pad[1], box.center[1] + pad[1]),
       xlabel="J [kg m²]", ylabel="mgl [N m]")
ax.legend(fontsize=7, loc="upper right")

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
volumes = pd.DataFrame({"area": [v for v, _ in sets.values()],
                        "area / area(P)": [v / area_P for v, _ in sets.values()],
                        "contains P": [bool(c) for _, c in sets.values()],
                        "contains truth": list(truth_in.values())},
                       index=pd.Index(list(sets), name="set"))
print(volumes)
vert_df = pd.DataFrame(vertices, columns=list(names), index=pd.Index(range(1, len(vertices) + 1), name="vertex"))
bounds_df = pd.DataFrame({"LP lo": box.lo, "LP hi": box.hi, "truth": theta_true, "Chebyshev centre": cheb_x},
                         index=pd.Index(names, name="parameter"))

# %% [markdown]
# ## Handout

# %%
page = Handout("Lesson 1: the feasible set",
               "A pendulum without friction, tau = J qdd + mgl sin q, is linear in theta = (J, mgl). A torque "
               "measured with an error bounded by e_max allows a strip of parameters; the feasible set is where all "
               "strips overlap. We build it strip by strip, then describe it exactly (vertices, LP box, Chebyshev "
               "centre) and by ellipses (maximum-volume inner, SDP outer, John).",
               setup={"model": "tau = J qdd + mgl sin q", "strips": N, "error bound": f"{E_MAX} N m (uniform noise)",
                      "truth": f"J = {theta_true[0]:.4g} kg m², mgl = {theta_true[1]:.4g} N m"})
page.section("Strips one by one",
             "Every measurement allows a strip of parameters whose width is 2 e_max / |w_k| across it. "
             "The feasible set (black outline) is what all strips share; it only shrinks as strips arrive, "
             "and it always contains the truth (star) because every error obeys its bound.")
page.figure(fig, "The strips (blue) of the first k measurements and their intersection (black).", name="strips")
page.section("The exact polygon and its ellipses",
             f"The polygon has {len(vertices)} vertices; {len(active)} of the {N} strips touch it (the others are "
             "redundant). The LP box gives exact per-parameter bounds, but it contains more than P. The Chebyshev "
             "centre is the centre of the largest inscribed disc. The maximum-volume inner ellipse lies inside P; "
             "the SDP outer ellipse and John's ellipse (inner scaled by 2) contain it.")
page.figure(fig2, "The exact polygon, its LP bounding box, Chebyshev disc, inner, SDP outer and John ellipses.",
            name="polygon")
page.table(volumes, "Areas (kg m² · N m) of the sets and their ratio to the exact polygon.", name="areas")
page.table(vert_df, "Vertices of the exact polygon (counter-clockwise).", name="vertices")
page.table(bounds_df, "Exact parameter bounds (LP), truth and Chebyshev centre.", name="bounds")
page.section("Exercises",
             "1. John's theorem says the inner ellipse scaled by p about its centre contains P. In 2-D, what "
             "area ratio John / inner follows? Check it against the areas table.\n\n"
             "2. Order the sets of the areas table by area. Which ones must be larger than P, which smaller, "
             "and why is the SDP outer ellipse not necessarily smaller than the LP box?\n\n"
             "3. Each vertex lies on the sides of two strips. Count the vertices and the touching strips given "
             "in the text: can a strip give more than two vertices? Would a new strip always remove a vertex?")
print(page.write(output_dir("lesson1_feasible_set") / "index.html"))
