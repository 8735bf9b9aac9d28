# %% [markdown]
# # Lesson 3: why the factorized form
#
# OBE can be run in two algebraically identical ways. The *standard* form updates the inverse
# information matrix M^-1 by Sherman-Morrison, a subtraction of a rank-one term; on
# ill-conditioned data rounding can make it indefinite, and the ellipsoid stops being one. The
# *factorized* form (Lesecq & Barraud) keeps M = X^T X with X triangular and updates X by Givens
# rotations; M stays positive definite by construction.

# %%
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from boundid.errors import SolverError
from boundid.estimators import OBE
from boundid.teaching import Handout, fast_mode, output_dir

FAST = fast_mode()
SEEDS = (0,) if FAST else (0, 1, 2)
P_DIM, E_MAX, CHUNK = 6, 1e-6, 250


def ill_conditioned(seed):
    """cond(W) ~ 1e8 rows, then 5000 nearly collinear rows; uniform errors within E_MAX."""
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=P_DIM)
    U, _ = np.linalg.qr(rng.normal(size=(P_DIM, P_DIM)))
    W1 = (rng.normal(size=(2000, P_DIM)) * np.logspace(0, -8, P_DIM)) @ U.T
    W2 = rng.normal(size=P_DIM) + 1e-8 * rng.normal(size=(5000, P_DIM))
    W = np.vstack([W1, W2])
    return theta, W, W @ theta + rng.uniform(-E_MAX, E_MAX, W.shape[0])


def run(form, theta, W, y):
    """Feed the data in chunks; after each chunk the smallest eigenvalue of the shape
    matrix sigma M^-1, the breakdown count and whether an Estimate can still be built."""
    obe = OBE(P_DIM, shape0=100.0, form=form)
    trace, est, error = [], None, ""
    for k in range(0, W.shape[0], CHUNK):
        try:
            est = obe.partial_fit(W[k:k + CHUNK], y[k:k + CHUNK], E_MAX)
        except SolverError as exc:
            est, error = None, "SolverError: " + ("not definite" if "definiteness" in str(exc) else str(exc)[:60])
        if form == "standard":    # the stored matrix itself: shape = sigma M^-1
            lam_min = float(np.linalg.eigvalsh(obe.shape())[0])
        else:                     # from the stored factor: sigma / lambda_max(X^T X), positive by construction
            lam_min = obe.sigma / float(np.linalg.eigvalsh(obe.information())[-1])
        trace.append((k + CHUNK, lam_min, obe.n_breakdowns))
    return trace, est, error


# %% [markdown]
# ## Well-conditioned data: the two forms agree

# %%
rng = np.random.default_rng(7)
theta_ok = rng.normal(size=P_DIM)
W_ok = rng.normal(size=(500, P_DIM))
y_ok = W_ok @ theta_ok + rng.uniform(-0.1, 0.1, 500)
agree = {f: OBE(P_DIM, shape0=100.0, form=f).fit(W_ok, y_ok, 0.1) for f in ("standard", "factorized")}
diff = np.abs(agree["standard"].set.shape - agree["factorized"].set.shape).max()
scale = np.abs(agree["factorized"].set.shape).max()
print(f"well conditioned: max |S_std - S_fac| / max |S| = {diff / scale:.2e}")

# %% [markdown]
# ## Ill-conditioned data

# %%
rows, traces = [], {}
for seed in SEEDS:
    theta, W, y = ill_conditioned(seed)
    cond = np.linalg.cond(W)
    for form in ("standard", "factorized"):
        trace, est, error = run(form, theta, W, y)
        traces[(seed, form)] = np.array(trace)
        rows.append({"run": f"{form}, seed {seed}", "cond(W)": cond, "breakdowns": trace[-1][2],
                     "smallest eig of shape": trace[-1][1],
                     "estimate": "ok" if est is not None else error,
                     "truth inside": bool(est.contains(theta)) if est is not None else False})
table = pd.DataFrame(rows).set_index("run")
print(table)

fig = Figure(figsize=(6.4, 3.4), layout="constrained")
ax = fig.subplots()
for (seed, form), tr in traces.items():
    vals = tr[:, 1]
    ax.plot(tr[:, 0], np.sign(vals) * np.log10(1.0 + np.abs(vals) * 1e20), "-" if form == "factorized" else "--",
            color="#0072B2" if form == "factorized" else "#D55E00", label=f"{form}, seed {seed}")
ax.axhline(0.0, color="k", lw=0.8)
ax.axvline(2000, color="#999999", lw=0.8, ls=":")
ax.set(xlabel="rows processed", ylabel="sign · log10(1 + 1e20 |λ_min|)")
ax.legend(fontsize=7)

# %%
page = Handout("Lesson 3: why the factorized form",
               "Two implementations of the same OBE recursion on data that are hard for floating point: 2000 rows "
               "with cond(W) ~ 1e8 followed by 5000 nearly collinear rows, errors within 1e-6. The standard form "
               "(Sherman-Morrison on M^-1) loses positive definiteness; the factorized form (Givens rotations on a "
               "triangular square root of M) cannot.",
               setup={"parameters": P_DIM, "rows": 7000, "error bound": E_MAX, "seeds": ", ".join(map(str, SEEDS)),
                      "prior": "ball of radius 10 about 0"})
page.section("When the data are benign",
             f"On 500 well-conditioned rows both forms give the same ellipsoid: the largest difference of the "
             f"shape matrices is {diff / scale:.1e} of their largest entry.")
page.section("When they are not",
             "The standard form counts a breakdown each time rounding makes w^T M^-1 w <= 0 and skips that row; "
             "afterwards M^-1 has a negative eigenvalue, the 'ellipsoid' is unbounded in some direction and "
             "building the Estimate raises SolverError. The factorized form keeps every eigenvalue positive and "
             "keeps the guarantee: the true parameters stay inside.")
page.text("For the factorized form the smallest eigenvalue is computed from its stored factor, as sigma divided by "
          "the largest eigenvalue of X^T X: forming M^-1 explicitly and asking eigvalsh would itself lose the tiny "
          "eigenvalues to rounding (the condition number of M is beyond 1e16), which is exactly the standard "
          "form's trouble.")
page.table(table, "Per seed and form: breakdowns, smallest eigenvalue of the shape sigma M^-1 at the end, whether "
                  "an Estimate could be built, and whether it contains the true parameters.", name="forms")
page.figure(fig, "Smallest eigenvalue of the shape sigma M^-1 as the rows arrive (signed log scale; below zero = "
                 "not an ellipsoid). The dotted line marks the start of the nearly collinear rows.",
            name="eigenvalues")
page.section("Exercises",
             "1. From the figure: does the standard form break on the ill-conditioned rows or only on the nearly "
             "collinear ones (after the dotted line)? Why is subtracting a rank-one term from M^-1 fragile when "
             "M^-1 already has eigenvalues 1e16 times smaller than its largest?\n\n"
             "2. The factorized form's smallest eigenvalue of the shape is tiny but positive. Is a tiny eigenvalue a "
             "problem for the guarantee? Check the 'truth inside' column.\n\n"
             "3. On the benign data the two forms differ by the relative amount given in the first section, far "
             "more than machine precision (2.2e-16) yet far less than the ellipsoid's size. Where can such "
             "differences come from in two recursions of 500 steps each?")
print(page.write(output_dir("lesson3_factorized_form") / "index.html"))
