# %% [markdown]
# # Lesson 2: the optimal bounding ellipsoid (OBE), step by step
#
# The exact polygon of lesson 1 needs all the data at once. The OBE algorithm keeps a single
# ellipse that surely contains the parameters and updates it strip by strip: the new ellipse is
# the smallest (volume-optimal weight) of a one-parameter family containing ellipse ∩ strip.
# A strip that does not cut the ellipse usefully is skipped; one that misses it is an outlier.
# Every sentence of the handout is written from the numbers this script computes.

# %%
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.ticker import MaxNLocator

from boundid.errors import InfeasibleDataError
from boundid.estimators import OBE, validate
from boundid.estimators.registry import METHODS
from boundid.models import LinearToy
from boundid.sets import Box, Ellipsoid, Polytope, step_ellipsoid
from boundid.teaching import Handout, fast_mode, fmt, output_dir, series_style

# the report's styles of the factorized OBE and OLS (boundid.estimators.registry)
OBE_COLOR = METHODS["obe"].style_for().color

FAST = fast_mode()
N = 14 if FAST else 40             # strips
E_MAX = 0.15                       # N m
QDD_MAX = 1.5                      # rad/s^2, as in lesson 1
OUTLIER = N - 4                    # this measurement gets a gross error of +2 N m
rng = np.random.default_rng(2)
theta_true = LinearToy().theta_true[:2]          # (J [kg m^2], mgl [N m])
q = rng.uniform(-1.2, 1.2, N)
qdd = rng.uniform(-QDD_MAX, QDD_MAX, N)
W = np.column_stack([qdd, np.sin(q)])
y = W @ theta_true + rng.uniform(-E_MAX, E_MAX, N)
y[OUTLIER] += 2.0
clean = np.setdiff1d(np.arange(N), [OUTLIER])
prior, prior_half = np.array([0.4, 4.5]), np.array([0.6, 1.2])   # design values +- ranges (contain the truth)
prior_box = (prior - prior_half, prior + prior_half)
LABELS = ("J [kg m²]", "mgl [N m]")


def frozen(E):
    """A copy of an OBE ellipse: the estimator's Ellipsoid shares its centre array with the running
    recursion (it moves on with the next update), so each step's ellipse is copied."""
    return Ellipsoid(E.center.copy(), E.shape.copy())



def polygon_area(rows):
    """Area of the exact polygon of the strips ``rows`` inside the prior box."""
    return Polytope(W[rows], y[rows], E_MAX, box=prior_box).volume()


# %% [markdown]
# ## One strip at a time
# For every measurement we record the ellipse before and after, what happened, and the weight
# lambda of the update M' = (1 - lambda) M + lambda w w^T / gamma^2 (read off the information
# matrix along the direction orthogonal to w, which only the factor 1 - lambda changes). The SDP
# `step_ellipsoid` computes the exact smallest ellipse around ellipse ∩ strip: OBE's volume step
# should match it.

# %%
obe = OBE(2, prior=Box.from_center(prior, prior_half), criterion="volume", names=("J", "mgl"))
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
upd = table[table["event"] == "update"]
sdp_gap = float(np.max(np.abs(upd["ln area OBE"] - upd["ln area SDP optimum"])))
counts = {e: int((table["event"] == e).sum()) for e in ("update", "skipped", "outlier")}
outlier_found = table["event"].iloc[OUTLIER] == "outlier"
other_outliers = [int(s) for s in table.index[table["event"] == "outlier"] if int(s) != OUTLIER + 1]

# What the skipped strips would still have told the exact polygon (consistent strips before them).
skip_cut = []
for k in np.flatnonzero(table["event"].to_numpy() == "skipped"):
    before = [j for j in range(k) if j != OUTLIER]
    if before:
        skip_cut.append(1.0 - polygon_area(before + [k]) / polygon_area(before))
skip_cut = np.array(skip_cut)

# %% [markdown]
# ## The frames
# Two panels with fixed axes: the whole prior, and a zoom on the final ellipse. Grey: the exact
# polygon of the consistent strips so far (inside the prior's box). Band: the current strip (blue
# if it updates the ellipse, grey if skipped, red if an outlier). Dashed: the ellipse before;
# solid: after.

# %%
COLORS = {"update": "#0072B2", "skipped": "#999999", "outlier": "#D55E00"}
final_P = Polytope(W[clean], y[clean], E_MAX)
whole = steps[0]["E_prev"].intervals()
whole = (whole[0] - 0.05 * (whole[1] - whole[0]), whole[1] + 0.05 * (whole[1] - whole[0]))
lo_f, hi_f = steps[-1]["E"].intervals()                  # a square about the final ellipse
half = 0.55 * (hi_f - lo_f).max()
zoom = (0.5 * (lo_f + hi_f) - half, 0.5 * (lo_f + hi_f) + half)
legend_handles = [Patch(fc="#dddddd", ec="k", label="exact polygon so far"),
                  Patch(fc=COLORS["update"], alpha=0.3, label="strip: update"),
                  Patch(fc=COLORS["skipped"], alpha=0.3, label="strip: skipped"),
                  Patch(fc=COLORS["outlier"], alpha=0.3, label="strip: outlier"),
                  Line2D([], [], ls="--", color="#56B4E9", lw=1.5, label="ellipse before"),
                  Line2D([], [], color=OBE_COLOR, lw=2, label="ellipse after"),
                  Line2D([], [], ls="", marker="*", color="k", ms=11, label="truth")]
frames, frame_labels = [], []
for k, s in enumerate(steps):
    fig = Figure(figsize=(10.0, 5.0), layout="constrained")
    panels = fig.subplots(1, 2)
    rows = [j for j in range(k + 1) if j != OUTLIER]
    poly = Polytope(W[rows], y[rows], E_MAX, box=prior_box)
    for ax, (lo, hi), title in ((panels[0], whole, "whole prior"), (panels[1], zoom, "zoom on the final ellipse")):
        ax.add_patch(PolygonPatch(poly.boundary(), closed=True, fc="#dddddd", ec="k", lw=0.8))
        band = Polytope(W[k:k + 1], y[k:k + 1], E_MAX, box=(lo, hi))
        if band.is_empty():                                  # an outlier's band may lie outside the window
            ax.text(0.5, 0.03, "the strip lies outside this window", transform=ax.transAxes, ha="center",
                    fontsize=10, color=COLORS[s["event"]])
        else:
            ax.add_patch(PolygonPatch(band.boundary(), closed=True, fc=COLORS[s["event"]], alpha=0.3,
                                      lw=0))
        ax.plot(*s["E_prev"].boundary().T, "--", color="#56B4E9", lw=1.5)
        ax.plot(*s["E"].boundary().T, color=OBE_COLOR, lw=2)
        ax.plot(*theta_true, "k*", ms=11)
        ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), aspect="equal", xlabel=LABELS[0], ylabel=LABELS[1])
        ax.set_title(title, fontsize=12)
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.tick_params(labelsize=10)
    panels[0].add_patch(Rectangle(zoom[0], *(zoom[1] - zoom[0]), fc="none", ec="k", ls=":", lw=1))
    head = f"strip {k + 1} of {N}: {s['event']}"
    if s["event"] == "update":
        head += f", λ = {s['lambda']:.3f}, ln area {s['ln area before']:.2f} → {s['ln area OBE']:.2f}"
    fig.suptitle(head, fontsize=14, color=COLORS[s["event"]])
    fig.legend(handles=legend_handles, loc="outside right upper", fontsize=10)
    frames.append(fig)
    frame_labels.append(head + ("; the truth is inside" if s["truth inside"] else "; the truth is OUTSIDE"))

# %% [markdown]
# ## Volume versus trace criterion
# Same clean data, two weight rules: minimise the area of each new ellipse, or the sum of its
# squared semi-axes (trace). Both are guaranteed; they differ in shape. `validate` compares each
# with the exact polygon (LP bounds, SDP reference ellipses).

# %%
prior_box = Box.from_center(prior, prior_half)
fits = {c: OBE(2, prior=prior_box, criterion=c, names=("J", "mgl")).fit(W[clean], y[clean], E_MAX)
        for c in ("volume", "trace")}
crit_rows = {}
for c, est in fits.items():
    cert = validate(est, final_P)
    crit_rows[c] = {"ln area": est.set.log_volume(), "trace of shape": float(np.trace(est.set.shape)),
                    "width / LP width, J": cert.width_ratio[0], "width / LP width, mgl": cert.width_ratio[1],
                    "ln-area excess over min outer": 2 * cert.excess_outer,
                    "contains P": cert.contains_polytope, "updates": est.n_updates,
                    "skipped": est.n_skipped}
crit = pd.DataFrame.from_dict(crit_rows, orient="index").rename_axis("criterion")
fig_c = Figure(figsize=(10.0, 4.4), layout="constrained")
ax1, ax2 = fig_c.subplots(1, 2)
ax1.add_patch(PolygonPatch(final_P.boundary(), closed=True, fc="#dddddd", ec="k", lw=1, label="exact polygon"))
for i, (c, est) in enumerate(fits.items()):
    st = series_style(i)
    ax1.plot(*est.set.boundary().T, color=st["color"], ls=st["linestyle"], lw=1.8, label=f"OBE ({c})")
    ax2.plot(est.history.index + 1, est.history.log_volumes, drawstyle="steps-post", color=st["color"],
             ls=st["linestyle"], marker=st["marker"], ms=4, lw=1.5)
ax1.plot(*theta_true, "k*", ms=10, label="truth")
ax1.set(xlabel=LABELS[0], ylabel=LABELS[1], aspect="equal")
ax1.xaxis.set_major_locator(MaxNLocator(4))
ax1.autoscale_view()
ax2.set(xlabel="strips processed", ylabel="ln area")
fig_c.legend(*ax1.get_legend_handles_labels(), loc="outside right upper", fontsize=10)

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
fig_o = Figure(figsize=(8.0, 4.8), layout="constrained")
ax = fig_o.subplots()
ax.add_patch(PolygonPatch(final_P.boundary(), closed=True, fc="#dddddd", ec="k", lw=1, label="exact polygon"))
for i, E in enumerate(order_ells):
    st = series_style(i)
    ax.plot(*E.boundary().T, color=st["color"], ls=st["linestyle"], lw=1.6, label=order_rows[i]["order"])
    ax.plot(*E.center, color=st["color"], marker=st["marker"], ms=7, ls="")
ax.plot(*theta_true, "k*", ms=10, label="truth")
ax.set(xlabel=LABELS[0], ylabel=LABELS[1], aspect="equal")
ax.xaxis.set_major_locator(MaxNLocator(4))
fig_o.legend(*ax.get_legend_handles_labels(), loc="outside right upper", fontsize=10,
             title="order of the strips (marker: centre)")

# %% [markdown]
# ## Handout: every sentence from the numbers above

# %%
vol, tr = crit.loc["volume"], crit.loc["trace"]
smaller_area = "volume" if vol["ln area"] < tr["ln area"] else "trace"
smaller_trace = "volume" if vol["trace of shape"] < tr["trace of shape"] else "trace"
if smaller_area == smaller_trace:
    rules_text = (f"the {smaller_area} rule ends with both the smaller area and the smaller trace: each rule is "
                  "optimal one step at a time, which does not make its own final measure the smallest")
else:
    rules_text = (f"the {smaller_area} rule ends with the smaller area and the {smaller_trace} rule with the "
                  "smaller trace")
all_inside = bool(table["truth inside"].all())
la = order["ln area"]
page = Handout("Lesson 2: OBE step by step",
               "The optimal bounding ellipsoid (OBE) algorithm processes one strip at a time and keeps one "
               "ellipse that is guaranteed to contain the parameters. We watch it on the 2-parameter pendulum of "
               "lesson 1, with one gross error injected, then compare the volume and trace weight rules and the "
               "effect of the order of the data.",
               setup={"model": "tau = J qdd + mgl sin q", "strips": N, "error bound": f"{E_MAX} N m",
                      "excitation": f"q uniform in ±1.2 rad, qdd uniform in ±{QDD_MAX} rad/s²",
                      "outlier": f"strip {OUTLIER + 1} (+2 N m)",
                      "prior": f"J = {prior[0]} ± {prior_half[0]} kg m², mgl = {prior[1]} ± {prior_half[1]} N m"})
page.key_points([
    f"Of {N} strips, the OBE updated its ellipse on {counts['update']}, skipped {counts['skipped']} that did not "
    f"cut it usefully and flagged {counts['outlier']} as outlier{'s' * (counts['outlier'] != 1)}; the injected "
    f"gross error (strip {OUTLIER + 1}) was {'caught' if outlier_found else 'NOT caught'}"
    + (f", and also strip(s) {', '.join(map(str, other_outliers))}." if other_outliers else "."),
    f"Each update is the exact one-step optimum: the OBE's ln area matches the SDP's smallest ellipse around "
    f"ellipse ∩ strip to within {sdp_gap:.1e}." if sdp_gap < 1e-3 else
    f"The OBE's ln area differs from the SDP's one-step optimum by up to {sdp_gap:.2g}.",
    "The truth stayed inside every ellipse of the recursion." if all_inside else
    f"The truth left the ellipse at strip {table.index[~table['truth inside']][0]}: a guarantee failed.",
    f"The final ellipse (volume rule) is {vol['width / LP width, J']:.2f}x (J) and "
    f"{vol['width / LP width, mgl']:.2f}x (mgl) as wide as the exact LP bounds. The order of the strips matters: "
    f"{len(perms)} orders give ln areas from {la.min():.2f} to {la.max():.2f}.",
])
page.section("The recursion, strip by strip",
             "One frame per measurement, on fixed axes: the whole prior on the left, a zoom on the final ellipse on "
             "the right (dotted square).")
page.stepper(frames, frame_labels, "OBE over the exact polygon (grey), strip by strip; dashed: previous ellipse, "
             "solid: new ellipse, band: the current strip.", name="obe-steps")
page.text("The ellipse shrinks only when the strip cuts it enough for the volume-optimal weight lambda to be "
          "positive; otherwise the strip is skipped at the cost of one test. A strip that misses the ellipse "
          "entirely contradicts the bounds: it is flagged as an outlier and ignored, which is only possible because "
          "the ellipse is guaranteed to contain the truth.")
page.table(table, "Every step: event, weight lambda, ln area before and after, the exact one-step optimum "
                  "(SDP; – when the strip misses the ellipse) and whether the truth is inside.", name="steps")
page.section("Volume versus trace",
             f"Both rules keep the guarantee (contains P: volume {'yes' if vol['contains P'] else 'NO'}, trace "
             f"{'yes' if tr['contains P'] else 'NO'}). The volume rule minimises the area of each new ellipse, the "
             f"trace rule the sum of its squared semi-axes. Here {rules_text} (volume against trace rule: ln area "
             f"{vol['ln area']:.2f} against {tr['ln area']:.2f}, trace {fmt(vol['trace of shape'])} against "
             f"{fmt(tr['trace of shape'])}).")
page.figure(fig_c, "Final ellipses of the two rules over the exact polygon (equal axis scales), and ln area against "
                   "strips processed.", name="criteria-ellipses")
page.table(crit, "Volume and trace rules against the exact polygon (width ratio 1 = the exact LP bound).",
           name="criteria")
page.section("Order dependence",
             f"The same strips in {len(perms) - 1} other orders give other final ellipses (ln area from "
             f"{la.min():.2f} to {la.max():.2f}): each step is optimal only given the previous ellipse, so the "
             "recursion is greedy. The polygon is the same. "
             + ("Every order keeps the truth inside." if order["truth inside"].all() else
                "In some order the truth is OUTSIDE: a guarantee failed."))
page.figure(fig_o, "Final OBE ellipses for the measured order and shuffled orders (equal axis scales).",
            name="order-ellipses")
page.table(order, "Final ln area and parameter intervals by order of the data.", name="order")
page.exercises([
    ("In the step table, compare 'ln area OBE' with 'ln area SDP optimum' on the update steps. What does the "
     "agreement tell you about the volume rule? Why is there no SDP value on the outlier row?",
     f"On the {counts['update']} update steps the two agree to within {sdp_gap:.1e} in ln area: the volume rule, "
     "applied to the strip clipped to the ellipse, is the exact smallest ellipse around ellipse ∩ strip (the "
     "one-step optimum). On an outlier row the strip misses the ellipse, the intersection is empty, and there is "
     "no ellipse to compute (the SDP reports infeasible data)."),
    ("Count the skipped strips. Does a skipped strip tell us nothing about the parameters? (Step through the "
     "frames: does its band still cut the grey polygon?)",
     f"{counts['skipped']} strips were skipped. "
     + (f"{int((skip_cut > 1e-9).sum())} of them still cut the exact polygon of the strips before them (area "
        f"reduced by up to {skip_cut.max():.0%}): the ellipse cannot use that information, the exact set can."
        if skip_cut.size else "None had a polygon before it to compare with.")),
    ("From the criteria table: which rule gives the smaller area, and which the smaller trace? Is either ellipse "
     "close to the exact bounds (width ratios)?",
     f"Here {rules_text}. Width ratios: "
     f"volume {vol['width / LP width, J']:.2f} (J), {vol['width / LP width, mgl']:.2f} (mgl); trace "
     f"{tr['width / LP width, J']:.2f}, {tr['width / LP width, mgl']:.2f}: both are wider than the exact bounds "
     "(ratio 1)."),
    ("Does the truth stay inside the final ellipse for every order of the data? Why must it?",
     f"{'Yes' if order['truth inside'].all() else 'No'}: {int(order['truth inside'].sum())} of {len(perms)} orders "
     "keep it inside. Each step keeps every parameter consistent with the strips so far, whatever the order, "
     "so the truth (consistent with every strip) is never dropped."),
])
print(page.write(output_dir("lesson2_obe_step_by_step") / "index.html"))
