# %% [markdown]
# # Lesson 4: statistics versus bounds
#
# Least squares gives a *confidence* ellipse: it contains the truth in 95 % of experiments if
# the noise is independent, zero-mean and the model is right. A bounded-error set *guarantees*
# the truth if every error obeys its bound and the model is right. We compare both under five
# kinds of error: uniform bounded noise, Gaussian noise, rare gross outliers, and two model
# errors: viscous friction (independent of the regressors here) and a spring torque k q
# (correlated with sin q) that the model leaves out. Every sentence of the handout is written
# from the numbers this script computes.

# %%
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.ticker import MaxNLocator

from boundid.estimators import OBE, ols
from boundid.estimators.registry import METHODS
from boundid.models import LinearToy
from boundid.sets import Box, Polytope
from boundid.teaching import Handout, fast_mode, fmt, output_dir

# the report's styles of the factorized OBE and OLS (boundid.estimators.registry)
OBE_COLOR = METHODS["obe"].style_for().color
OLS_COLOR = METHODS["ols"].style_for().color

FAST = fast_mode()
N = 60 if FAST else 200            # samples per experiment
REPEATS = 20 if FAST else 200      # experiments for the coverage columns
E_MAX = 0.15                       # the error bound the set estimators assume, N m
QDD_MAX = 1.5                      # rad/s^2, as in lessons 1 and 2
toy = LinearToy()
theta_true = toy.theta_true[:2]    # (J, mgl)
B_TRUE = 0.06                      # N m s/rad, viscous friction (scenario "friction")
K_TRUE = 0.012                     # N m/rad, a spring the model leaves out (scenario "spring")
prior, prior_half = np.array([0.4, 4.5]), np.array([0.6, 1.2])
SCENARIOS = {
    "uniform bounded": "uniform errors within ±e_max",
    "Gaussian": "Gaussian errors, sigma = e_max / 2 (5 % of them exceed the bound)",
    "rare outliers": "uniform within ±e_max, 2 % replaced by gross errors of 1-2 N m",
    "friction": f"uniform within ±e_max, plus friction {B_TRUE} qd (qd drawn independently of q and qdd)",
    "spring": f"uniform within ±e_max, plus a spring torque {K_TRUE} q (correlated with sin q)",
}
MODEL_ERRORS = ("friction", "spring")
LABELS = ("J [kg m²]", "mgl [N m]")


def experiment(kind, rng, n=N):
    q, qd, qdd = rng.uniform(-1.2, 1.2, n), rng.uniform(-3.0, 3.0, n), rng.uniform(-QDD_MAX, QDD_MAX, n)
    W = np.column_stack([qdd, np.sin(q)])
    e = rng.uniform(-E_MAX, E_MAX, n)
    if kind == "Gaussian":
        e = rng.normal(0.0, E_MAX / 2, n)
    elif kind == "rare outliers":
        bad = rng.random(n) < 0.02
        e[bad] = rng.choice([-1.0, 1.0], bad.sum()) * rng.uniform(1.0, 2.0, bad.sum())
    elif kind == "friction":
        e = e + B_TRUE * qd
    elif kind == "spring":
        e = e + K_TRUE * q
    return W, W @ theta_true + e


def guaranteed(W, y):
    """The exact polygon if the data are consistent with E_MAX, else None; and gamma* (> 1: empty)."""
    P = Polytope(W, y, E_MAX)
    cons = P.consistency()
    return (None if cons.empty else P), float(cons)



# %% [markdown]
# ## One experiment per scenario

# %%
rng = np.random.default_rng(4)
fig = Figure(figsize=(10.0, 6.4), layout="constrained")
axes = fig.subplots(2, 3).ravel()
rows = {}
for ax, kind in zip(axes, SCENARIOS, strict=False):
    W, y = experiment(kind, rng)
    ls = ols(W, y, level=0.95, names=("J", "mgl"))
    P, gamma = guaranteed(W, y)
    obe = OBE(2, prior=Box.from_center(prior, prior_half), names=("J", "mgl")).fit(W, y, E_MAX)
    if P is not None:
        ax.add_patch(PolygonPatch(P.boundary(), closed=True, fc="#dddddd", ec="k", lw=1))
    ax.plot(*obe.set.boundary().T, color=OBE_COLOR, lw=1.8)
    ax.plot(*obe.center, "o", color=OBE_COLOR, ms=5)      # visible even when the ellipse is tiny
    ax.plot(*ls.set.boundary().T, color=OLS_COLOR, lw=1.8, ls="--")
    ax.plot(*theta_true, "k*", ms=10)
    drawn = np.vstack([obe.set.boundary(), ls.set.boundary(), theta_true[None, :]]
                      + ([P.vertices()] if P is not None else []))
    mid, half = 0.5 * (drawn.min(axis=0) + drawn.max(axis=0)), 0.55 * np.ptp(drawn, axis=0).max()
    ax.set(xlim=(mid[0] - half, mid[0] + half), ylim=(mid[1] - half, mid[1] + half), aspect="equal",
           xlabel=LABELS[0], ylabel=LABELS[1])
    ax.set_title(kind, fontsize=12)
    ax.xaxis.set_major_locator(MaxNLocator(3))
    ax.yaxis.set_major_locator(MaxNLocator(4))
    rows[kind] = {"truth in exact set": bool(P is not None and P.contains(theta_true)),
                  "truth in OBE": obe.contains(theta_true), "truth in OLS": ls.contains(theta_true),
                  "gamma*": gamma, "exact set": "empty" if P is None else "non-empty",
                  "OBE area": obe.set.volume(), "OLS area": ls.set.volume(),
                  "OBE outliers": obe.n_outliers}
for ax in axes[len(SCENARIOS):]:
    ax.set_axis_off()
fig.legend(handles=[Patch(fc="#dddddd", ec="k", label="exact set"),
                    Line2D([], [], color=OBE_COLOR, lw=1.8, marker="o", ms=5,
                           label="OBE (dot: centre)"),
                    Line2D([], [], color=OLS_COLOR, lw=1.8, ls="--", label="OLS 95 %"),
                    Line2D([], [], ls="", marker="*", color="k", ms=10, label="truth")],
           loc="outside right upper", fontsize=10)
single = pd.DataFrame.from_dict(rows, orient="index").rename_axis("scenario")

# %% [markdown]
# ## Many experiments: how often does each set contain the truth?

# %%
cov_rows, ols_err = {}, {}
for kind in SCENARIOS:
    hits, empty, gammas, errs = np.zeros(2), 0, [], []
    for _ in range(REPEATS):
        W, y = experiment(kind, rng)
        obe = OBE(2, prior=Box.from_center(prior, prior_half)).fit(W, y, E_MAX)
        ls = ols(W, y)
        hits += [ls.contains(theta_true), obe.contains(theta_true)]
        g = float(Polytope(W, y, E_MAX).consistency())
        empty += g > 1.0
        gammas.append(g)
        errs.append((ls.center - theta_true) / ls.statistics.std_err)
    cov_rows[kind] = {"OLS coverage": hits[0] / REPEATS, "OBE coverage": hits[1] / REPEATS,
                      "exact set empty": empty / REPEATS, "largest gamma*": max(gammas)}
    ols_err[kind] = np.array(errs)     # OLS error in standard errors, per experiment and parameter
coverage = pd.DataFrame.from_dict(cov_rows, orient="index").rename_axis("scenario")
print(single, coverage, sep="\n")

# More samples against a model error: OLS coverage with 4 N samples per experiment.
more = {}
for kind in MODEL_ERRORS:
    hits = [ols(*experiment(kind, rng, 4 * N)).contains(theta_true) for _ in range(REPEATS)]
    more[kind] = float(np.mean(hits))
bias = {kind: np.abs(ols_err[kind].mean(axis=0)) for kind in SCENARIOS}   # |mean error| in std errors

# %% [markdown]
# ## Handout: every sentence from the numbers above

# %%
c, s = coverage, single
se95 = np.sqrt(0.95 * 0.05 / REPEATS)          # binomial standard error of a 95 % coverage


def near95(x):
    return abs(x - 0.95) <= 2 * se95


def pct(x):
    return f"{x:.0%}"


def cov_text(kind):
    return f"OBE {pct(c.loc[kind, 'OBE coverage'])}, OLS {pct(c.loc[kind, 'OLS coverage'])}"


u = "uniform bounded"
smaller_u = "OBE" if s.loc[u, "OBE area"] < s.loc[u, "OLS area"] else "OLS"
worst_bias = max(MODEL_ERRORS, key=lambda k: bias[k].max())
page = Handout("Lesson 4: statistics versus bounds",
               "The pendulum tau = J qdd + mgl sin q again, now with five kinds of error. Ordinary least squares "
               "(OLS) gives a 95 % confidence ellipse; the exact feasible polygon and the OBE ellipse assume every "
               "error is within e_max. Which set contains the truth depends on which assumption the data obey.",
               setup={"samples": N, "experiments for coverage": REPEATS, "error bound e_max": f"{E_MAX} N m",
                      **{f"scenario '{k}'": v for k, v in SCENARIOS.items()}})
page.key_points([
    f"Errors within the bound (uniform): the OBE contains the truth in {pct(c.loc[u, 'OBE coverage'])} of "
    f"{REPEATS} experiments, OLS in {pct(c.loc[u, 'OLS coverage'])} (nominal 95 %).",
    f"Errors beyond the bound break the guarantee: Gaussian noise makes the exact set empty in "
    f"{pct(c.loc['Gaussian', 'exact set empty'])} of the experiments and the OBE's coverage falls to "
    f"{pct(c.loc['Gaussian', 'OBE coverage'])}; OLS keeps {pct(c.loc['Gaussian', 'OLS coverage'])}.",
    f"Rare gross outliers: {cov_text('rare outliers')}; the OBE skips the strips that miss its ellipse.",
    f"Model errors: friction independent of the regressors gives {cov_text('friction')}; a spring correlated "
    f"with sin q gives {cov_text('spring')}, and with 4x the samples OLS's coverage goes from "
    f"{pct(c.loc['spring', 'OLS coverage'])} to {pct(more['spring'])}.",
])
page.section("One experiment per scenario",
             "gamma* is the smallest factor by which all bounds must be enlarged for the data to be consistent "
             "(an LP): gamma* > 1 means the exact set is empty and the data contradict the bounds. OBE then "
             "skips the strips that miss its ellipse (outliers) and carries on, without a guarantee. "
             f"In the experiments drawn here gamma* ranges from {s['gamma*'].min():.3g} ({s['gamma*'].idxmin()}) to "
             f"{s['gamma*'].max():.3g} ({s['gamma*'].idxmax()}).")
page.figure(fig, "Exact set (grey, when not empty), OBE ellipse and OLS 95 % confidence ellipse, one experiment "
                 "per scenario (equal axis scales).", name="scenarios")
page.table(single, "One experiment per scenario: which sets contain the truth, gamma*, the exact set, the areas "
                   "(kg m² · N m) and the strips the OBE flagged as outliers.", name="one-experiment")
page.section("Coverage over many experiments")
page.table(coverage, f"Fraction of {REPEATS} experiments in which each set contains the truth (coverage), in which "
                     "the exact set is empty, and the largest gamma* met.", name="coverage")
page.exercises([
    ("Under uniform bounded noise, which set is smaller, and which one contains the truth every time (coverage "
     "column)? Is OLS's coverage close to its nominal 95 %?",
     f"In the drawn experiment the {smaller_u} ellipse is smaller (OBE area {fmt(s.loc[u, 'OBE area'])}, OLS "
     f"{fmt(s.loc[u, 'OLS area'])}). Coverage: {cov_text(u)}. With {REPEATS} experiments a true 95 % coverage "
     f"would be measured within ±{2 * se95:.1%} (two binomial standard errors): OLS's "
     f"{pct(c.loc[u, 'OLS coverage'])} is {'within' if near95(c.loc[u, 'OLS coverage']) else 'outside'} that range."),
    ("Under Gaussian noise the bounds are sometimes violated. What does gamma* say, and what happens to OBE's "
     "coverage? What would you change in e_max to restore the guarantee?",
     f"gamma* was {s.loc['Gaussian', 'gamma*']:.3g} in the drawn experiment and at most "
     f"{c.loc['Gaussian', 'largest gamma*']:.3g} over {REPEATS}; the exact set was empty in "
     f"{pct(c.loc['Gaussian', 'exact set empty'])} of them and the OBE covered the truth in "
     f"{pct(c.loc['Gaussian', 'OBE coverage'])}. Raising e_max to at least "
     f"{c.loc['Gaussian', 'largest gamma*'] * E_MAX:.3g} N m (largest gamma* times e_max) would have made every "
     "one of these experiments consistent; for Gaussian noise no finite bound is sure, so the guarantee becomes a "
     "probability again."),
    ("The two model-error scenarios both add a small, bounded, systematic error. Compare OLS's coverage in the "
     "two. Why do they differ, and does collecting more samples help?",
     f"Coverage: friction {cov_text('friction')}; spring {cov_text('spring')}. The OLS error averaged over the "
     f"experiments is at most {bias['friction'].max():.2f} standard errors with friction (qd is drawn "
     "independently of the regressors, so the friction torque acts as extra zero-mean noise) but "
     f"{bias['spring'].max():.2f} with the spring (k q is correlated with sin q, so it biases mgl). More "
     "samples shrink the standard error but not the bias: with 4x the samples OLS's coverage is "
     f"{pct(more['spring'])} (spring) and {pct(more['friction'])} (friction). The OBE covers the truth in "
     f"{pct(c.loc[worst_bias, 'OBE coverage'])} ({worst_bias}): its bound does not allow for the model error, "
     f"although the exact set was empty in only {pct(c.loc[worst_bias, 'exact set empty'])} of the experiments: "
     "a non-empty set does not prove the model right."),
])
print(page.write(output_dir("lesson4_statistics_vs_bounds") / "index.html"))
