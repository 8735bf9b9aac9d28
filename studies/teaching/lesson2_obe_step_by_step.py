# %% [markdown]
# # Lesson 2: the optimal bounding ellipsoid (OBE), step by step
#
# The exact polygon of lesson 1 needs all the data at once. The OBE algorithm keeps a single
# ellipse that surely contains the parameters and updates it strip by strip: the new ellipse is
# the smallest (volume-optimal weight) of a one-parameter family containing ellipse ∩ strip.
# A strip that does not cut the ellipse usefully is skipped; one that misses it is an outlier.

# %%
import io

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch
from PIL import Image

from boundid.errors import InfeasibleDataError
from boundid.estimators import OBE, validate
from boundid.models import LinearToy
from boundid.report import color_for
from boundid.sets import Box, Ellipsoid, Polytope, step_ellipsoid
from boundid.teaching import Handout, fast_mode, output_dir

FAST = fast_mode()
N = 14 if FAST else 40             # strips
E_MAX = 0.15                       # N m
OUTLIER = N - 4                    # this measurement gets a gross error of +2 N m
rng = np.random.default_rng(2)
theta_true = LinearToy().theta_true[:2]          # (J [kg m^2], mgl [N m])
q = rng.uniform(-1.2, 1.2, N)
qdd = rng.uniform(-8.0, 8.0, N)
W = np.column_stack([qdd, np.sin(q)])
y = W @ theta_true + rng.uniform(-E_MAX, E_MAX, N)
y[OUTLIER] += 2.0
clean = np.setdiff1d(np.arange(N), [OUTLIER])
prior, prior_half = np.array([0.35, 4.0]), np.array([0.3, 3.0])   # design values +- ranges (contain the truth)


def frozen(E):
    """A copy of an OBE ellipse: the estimator's Ellipsoid shares its centre array with the running
    recursion (it moves on with the next update), so each step's ellipse is copied."""
    return Ellipsoid(E.center.copy(), E.shape.copy())


def ordered(v):
    c = v.mean(axis=0)
    return v[np.argsort(np.arctan2(v[:, 1] - c[1], v[:, 0] - c[0]))]


# %% [markdown]
# ## One strip at a time
# For every measurement we record the ellipse before and after, what happened, and the weight
# lambda of the update M' = (1 - lambda) M + lambda w w^T / gamma^2 (read off the information
# matrix along the direction orthogonal to w, which only the factor 1 - lambda changes). The SDP
# `step_ellipsoid` computes the exact smallest ellipse around ellipse ∩ strip: OBE's volume step
# should match it.

# %%
obe = OBE(2, prior=Box.from_center(prior, prior_half), criterion="volume", names=("J", "mgl"))
E0 = obe.ellipsoid()
window = E0.intervals()
steps = []
for k in range(N):
    E_prev, M_prev = frozen(obe.ellipsoid()), obe.information()
    n_out, n_skip = obe.estimate().n_outliers, obe.n_skipped
    est = obe.update(W[k], y[k], E_MAX)
    event = "outlier" if est.n_outliers > n_out else "skipped" if obe.n_skipped > n_skip else "update"
    v = np.array([-W[k, 1], W[k, 0]])                       # orthogonal to w_k
    lam = 1.0 - (v @ obe.information() @ v) / (v @ M_prev @ v) if event == "update" else 0.0
    try:
        sdp = step_ellipsoid(E_prev, W[k], y[k], E_MAX).ellipsoid.log_volume()
    except InfeasibleDataError:
        sdp = np.nan                                         # the strip misses the ellipse
    steps.append({"strip": k + 1, "event": event, "lambda": lam, "ln area before": E_prev.log_volume(),
                  "ln area OBE": est.set.log_volume(), "ln area SDP optimum": sdp,
                  "truth inside": bool(est.contains(theta_true)), "E_prev": E_prev, "E": frozen(est.set)})
table = pd.DataFrame([{k: v for k, v in s.items() if k not in ("E_prev", "E")} for s in steps])
table = table.set_index(table["strip"].astype(str)).drop(columns="strip")   # text labels for the page tables
print(table)

# %% [markdown]
# ## The animation
# Grey: the exact polygon of the consistent strips so far (inside the prior's box). Blue band:
# the current strip (grey if skipped, red if an outlier). Dashed: the ellipse before; solid: after.

# %%
COLORS = {"update": "#0072B2", "skipped": "#999999", "outlier": "#D55E00"}
frames = []
for k, s in enumerate(steps):
    fig = Figure(figsize=(3.8, 3.2), layout="constrained")
    ax = fig.subplots()
    lo, hi = s["E_prev"].intervals()
    pad = 0.15 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    rows = [j for j in range(k + 1) if j != OUTLIER]
    if rows:
        poly = Polytope(W[rows], y[rows], E_MAX, box=window)
        ax.add_patch(PolygonPatch(ordered(poly.vertices()), closed=True, fc="#dddddd", ec="k", lw=0.8))
    band = Polytope(W[k:k + 1], y[k:k + 1], E_MAX, box=(lo, hi))
    if not band.is_empty():                                  # an outlier's band may lie outside the window
        ax.add_patch(PolygonPatch(ordered(band.vertices()), closed=True, fc=COLORS[s["event"]], alpha=0.25, lw=0))
    ax.plot(*s["E_prev"].boundary().T, "--", color="#56B4E9", lw=1)
    ax.plot(*s["E"].boundary().T, color=color_for("OBE-factorized"), lw=1.6)
    ax.plot(*theta_true, "k*", ms=7)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), xlabel="J [kg m²]", ylabel="mgl [N m]")
    ax.set_title(f"strip {k + 1}: {s['event']}" + (f", λ = {s['lambda']:.3f}" if s["event"] == "update" else ""),
                 fontsize=9, color=COLORS[s["event"]])
    ax.tick_params(labelsize=7)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    frames.append(Image.open(buf).convert("RGB").quantize(colors=64))
gif = io.BytesIO()
frames[0].save(gif, format="GIF", save_all=True, append_images=frames[1:] + [frames[-1]] * 3, duration=700, loop=0)
print(f"GIF: {len(frames)} frames, {gif.tell() / 1e3:.0f} kB")

# %% [markdown]
# ## Volume versus trace criterion
# Same clean data, two weight rules: minimise the area of each new ellipse, or the sum of its
# squared semi-axes (trace). Both are guaranteed; they differ in shape. `validate` compares each
# with the exact polygon (LP bounds, SDP reference ellipses).

# %%
P = Polytope(W[clean], y[clean], E_MAX)
fits = {c: OBE(2, prior=Box.from_center(prior, prior_half), criterion=c, names=("J", "mgl"))
        .fit(W[clean], y[clean], E_MAX) for c in ("volume", "trace")}
crit_rows = {}
for c, est in fits.items():
    cert = validate(est, P)
    crit_rows[c] = {"ln area": est.set.log_volume(), "trace of shape": float(np.trace(est.set.shape)),
                    "width / LP width, J": cert.width_ratio[0], "width / LP width, mgl": cert.width_ratio[1],
                    "ln-area excess over min outer": 2 * cert.excess_outer,
                    "contains P": cert.contains_polytope, "updates": est.n_updates,
                    "skipped": est.n_skipped}
crit = pd.DataFrame.from_dict(crit_rows, orient="index").rename_axis("criterion")
fig_c = Figure(figsize=(8.4, 3.4), layout="constrained")
ax1, ax2 = fig_c.subplots(1, 2)
ax1.add_patch(PolygonPatch(ordered(P.vertices()), closed=True, fc="#dddddd", ec="k", lw=1, label="exact polygon"))
for c, est, ls in (("volume", fits["volume"], "-"), ("trace", fits["trace"], "--")):
    ax1.plot(*est.set.boundary().T, ls, lw=1.5, label=f"OBE ({c})")
ax1.plot(*theta_true, "k*", ms=8, label="truth")
ax1.set(xlabel="J [kg m²]", ylabel="mgl [N m]")
ax1.legend(fontsize=7)
ax1.autoscale_view()
for c, est, ls in (("volume", fits["volume"], "-"), ("trace", fits["trace"], "--")):
    ax2.plot(est.history.index + 1, est.history.log_volumes, ls, label=f"OBE ({c})")
ax2.set(xlabel="strips processed", ylabel="ln area")
ax2.legend(fontsize=7)

# %% [markdown]
# ## Order dependence
# The exact polygon does not depend on the order of the strips; the recursive ellipse does.

# %%
perms = [clean] + [rng.permutation(clean) for _ in range(2 if FAST else 5)]
order_rows, order_ells = [], []
for i, perm in enumerate(perms):
    est = OBE(2, prior=Box.from_center(prior, prior_half), criterion="volume").fit(W[perm], y[perm], E_MAX)
    lo, hi = est.intervals
    order_ells.append(est.set)
    order_rows.append({"order": "as measured" if i == 0 else f"shuffle {i}", "ln area": est.set.log_volume(),
                       "J lo": lo[0], "J hi": hi[0], "mgl lo": lo[1], "mgl hi": hi[1],
                       "truth inside": bool(est.contains(theta_true))})
order = pd.DataFrame(order_rows).set_index("order")
fig_o = Figure(figsize=(4.8, 3.6), layout="constrained")
ax = fig_o.subplots()
ax.add_patch(PolygonPatch(ordered(P.vertices()), closed=True, fc="#dddddd", ec="k", lw=1))
for i, E in enumerate(order_ells):
    ax.plot(*E.boundary().T, lw=1.2, label=order_rows[i]["order"])
ax.plot(*theta_true, "k*", ms=8)
ax.set(xlabel="J [kg m²]", ylabel="mgl [N m]")
ax.legend(fontsize=7)

# %%
page = Handout("Lesson 2: OBE step by step",
               "The optimal bounding ellipsoid (OBE) algorithm processes one strip at a time and keeps one "
               "ellipse that is guaranteed to contain the parameters. We watch it on the 2-parameter pendulum of "
               "lesson 1, with one gross error injected, then compare the volume and trace weight rules and the "
               "effect of the order of the data.",
               setup={"model": "tau = J qdd + mgl sin q", "strips": N, "error bound": f"{E_MAX} N m",
                      "outlier": f"strip {OUTLIER + 1} (+2 N m)",
                      "prior": f"J = {prior[0]} ± {prior_half[0]}, mgl = {prior[1]} ± {prior_half[1]}"})
page.section("The recursion, strip by strip",
             "Each frame shows one measurement. The ellipse shrinks only when the strip cuts it enough for the "
             "volume-optimal weight lambda to be positive; otherwise the strip is skipped at the cost of one test. "
             "A strip that misses the ellipse entirely contradicts the bounds: it is flagged as an outlier and "
             "ignored, which is only possible because the ellipse is guaranteed to contain the truth.")
page.image(gif.getvalue(), "OBE over the exact polygon (grey), strip by strip; dashed: previous ellipse.",
           name="obe_steps")
page.table(table, "Every step: event, weight lambda, ln area before and after, the exact one-step optimum "
                  "(SDP; NaN when the strip misses the ellipse) and whether the truth is inside.", name="steps")
page.section("Volume versus trace", "Both rules keep the guarantee; the volume rule minimises the area of each "
             "new ellipse, the trace rule the sum of its squared semi-axes, which favours rounder ellipses.")
page.figure(fig_c, "Final ellipses of the two rules over the exact polygon, and ln area against strips.",
            name="criteria")
page.table(crit, "Volume and trace rules against the exact polygon (width ratio 1 = the exact LP bound).",
           name="criteria")
page.section("Order dependence", "The same strips in another order give another final ellipse: each step is "
             "optimal only given the previous ellipse, so the recursion is greedy. The polygon is the same.")
page.figure(fig_o, "Final OBE ellipses for the measured order and shuffled orders.", name="order")
page.table(order, "Final ln area and parameter intervals by order of the data.", name="order")
page.section("Exercises",
             "1. In the step table, compare 'ln area OBE' with 'ln area SDP optimum' on the update steps. What "
             "does the agreement tell you about the volume rule? Why is the SDP entry NaN on the outlier row?\n\n"
             "2. Count the skipped strips. Does a skipped strip tell us nothing about the parameters? (Look at "
             "whether its band still cuts the grey polygon in the animation.)\n\n"
             "3. From the criteria table: which rule gives the smaller area, and which the smaller trace? Is "
             "either ellipse close to the exact bounds (width ratios)?")
print(page.write(output_dir("lesson2_obe_step_by_step") / "index.html"))
