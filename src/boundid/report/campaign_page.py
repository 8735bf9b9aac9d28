"""The summary page of a Monte Carlo campaign: coverage of the truth, width over the exact width,
bias and RMSE, time per replicate, per estimator and scenario.

The page opens with its findings (computed sentences, :func:`findings`): first every scenario whose
error bound is broken at the truth, with the rate and the share of replicates whose guaranteed sets
still contain the truth; then one small table, estimator x scenario, each cell "coverage · failure
rate · width / exact" (:func:`overview`), words where a number cannot exist; failures follow,
grouped by message with counts (:func:`failure_groups`); every other table and figure is folded
(<details>). One coverage throughout (:data:`COVERAGE`, stated once on the page): the share of
replicates whose set contains the whole true parameter vector.

Every number is computed from the campaign's Parquet files (``<out>/data/``); the page is
written to ``<out>/index.html`` with its tables and figures beside it, and ``<out>/data/index.html``
lists the replicate files (the page links that list, never the bare folder).
"""

from __future__ import annotations

import html
import re
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from boundid.errors import InputError
from boundid.report.figures import DPI, color_for, method_styles, study_styles
from boundid.report.html import Page, render_page, site_header
from boundid.report.output import replace_folder, write_file_atomically
from boundid.studies.campaign import DATA_DIR, EXACT_LABEL, CampaignResult, parameter_errors, summarize

KEYS = ["scenario", "estimator", "regression"]
MAX_SCENARIOS_PER_TABLE = 4  # the opening table's columns: more scenarios continue in a second table
_HATCHES = (None, "//", "..", "xx")  # one per regression model; the colour is the estimator's


def _keyed(df: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """The key columns joined into one text index ("scenario / estimator / regression ...")."""
    index = df[keys].astype(str).agg(" / ".join, axis=1).rename(" / ".join(keys))
    return df.drop(columns=keys).set_index(index)


def _grouped_bars(summary: pd.DataFrame, column: str, ylabel: str, *, log: bool = False,
                  reference: float | None = None, reference_label: str = "") -> Figure:
    """One group of bars per scenario, one bar per estimator x regression (colour: estimator, hatch: regression)."""
    scen = list(dict.fromkeys(summary["scenario"]))
    labels = list(dict.fromkeys(summary["estimator"] + " / " + summary["regression"]))
    regs = list(dict.fromkeys(summary["regression"]))
    fig = Figure(figsize=(min(11.0, max(4.5, 2.0 + 0.22 * len(scen) * len(labels))), 3.6), dpi=DPI,
                 layout="constrained")
    ax = fig.subplots()
    step = 0.8 / max(len(labels), 1)
    x = np.arange(len(scen))
    for k, lab in enumerate(labels):
        rows = summary[(summary["estimator"] + " / " + summary["regression"]) == lab].set_index("scenario")
        vals = rows[column].reindex(scen).to_numpy(dtype=float)
        ax.bar(x - 0.4 + (k + 0.5) * step, vals, width=step, color=color_for(lab.split(" / ")[0]), label=lab,
               edgecolor="white", linewidth=0.5, hatch=_HATCHES[regs.index(lab.split(" / ")[1]) % len(_HATCHES)])
    if reference is not None:
        ax.axhline(reference, color="black", lw=1.0, ls="--", label=reference_label)
    if log:
        ax.set_yscale("log")
    ax.set_xticks(x, scen, rotation=20 if len(scen) > 3 else 0)
    ax.set_ylabel(ylabel)
    ax.grid(axis="y", which="both", alpha=0.3)
    fig.legend(loc="outside upper center", fontsize=7, ncols=min(len(labels) + 1, 3), frameon=False)
    return fig


def _pct(x: float) -> str:
    return f"{x:.3g} %"


#: the one coverage of this page: the tables, the figure and the findings all count it
COVERAGE = ("the share of an estimator's completed replicates whose set contains the whole true "
            "parameter vector (its guaranteed set, its confidence set at its level, or for LP exact the exact "
            "feasible polytope, an empty one counting as a set that does not contain it)")


def _row_label(summary: pd.DataFrame) -> pd.Series:
    """"estimator", or "estimator / regression" when the campaign has several regressions."""
    several = summary["regression"].nunique() > 1
    return summary["estimator"] + (" / " + summary["regression"] if several else "")


def scenario_bounds(table: pd.DataFrame) -> pd.DataFrame:
    """Per scenario, the exact stage's bound at the truth: ``replicates``, ``checked`` (replicates
    whose max |y - w^T theta_true| / e_max on the exact regression is known), ``broken`` (those where
    it exceeds 1), ``bound`` (that e_max in words, "" if the files do not record it), ``exact_failed``
    and ``exact_empty`` (replicates where the exact LP failed, or found the feasible set empty)."""
    ratio = (table["truth_error_ratio"].astype(float) if "truth_error_ratio" in table
             else pd.Series(np.nan, index=table.index))
    t = table.assign(ratio=ratio)
    rows = []
    for sc, g in t.groupby("scenario", sort=False):
        reps = g.drop_duplicates("replicate")
        lp = g[g["estimator"] == EXACT_LABEL]
        checked = reps[reps["ratio"].notna()]
        bound = g["exact_bound"].dropna() if "exact_bound" in g else pd.Series(dtype=str)
        rows.append({"scenario": sc, "replicates": len(reps), "checked": len(checked),
                     "broken": int((checked["ratio"] > 1.0).sum()), "bound": str(bound.iloc[0]) if len(bound) else "",
                     "exact_failed": lp.loc[lp["kind"] == "failed", "replicate"].nunique(),
                     "exact_empty": len(set(checked["replicate"]) - set(lp["replicate"]))})
    return pd.DataFrame(rows).set_index("scenario")


def _no_width(b) -> str:
    """Why a set has no width over the exact width in a scenario (words, for a cell)."""
    if b is None or (b["checked"] == 0 and b["exact_failed"] == 0):
        return "no width (no exact LP)"
    if b["exact_empty"] == b["replicates"]:
        return "no width (exact set empty)"
    if b["exact_failed"] + b["exact_empty"] >= b["replicates"]:
        return f"no width (exact LP failed in {b['exact_failed']}, empty in {b['exact_empty']})"
    return "no width (no replicate with both sets)"


def _cell(r, b) -> str:
    """An overview cell: "coverage · failure rate · width / exact", words where a number cannot exist."""
    n = int(b["replicates"]) if b is not None else int(r["replicates"])
    if r["kind"] == "failed":
        return f"failed in every replicate ({int(r['failed'])} of {n})"
    done = int(r["replicates"] - r["failed"])
    empty = r.get("empty_replicates", np.nan)
    if np.isfinite(r["contains_truth_pct"]):
        cov = _pct(r["contains_truth_pct"])
    else:
        cov = "no set (a point estimate)" if r["kind"] == "point" else "no truth to compare with"
    notes = []
    if r["kind"] in ("guaranteed", "exact") and done and r["bound_held_replicates"] < done:
        notes.append(f"bound broken in {done - int(r['bound_held_replicates'])} of {done}")
    if np.isfinite(empty) and empty > 0:
        notes.append(f"set empty in {int(empty)} of {int(r['replicates'])}")
    if notes:
        cov += f" ({'; '.join(notes)})"
    fail = _pct(100.0 * r["failed"] / n) if n else "no replicate"
    if np.isfinite(r["width_ratio_median"]):
        width = f"{r['width_ratio_median']:.3g}"
    elif np.isfinite(empty) and empty == r["replicates"]:
        width = "no width (set empty)"
    else:
        width = _no_width(b)
    return f"{cov} · {fail} · {width}"


def overview(summary: pd.DataFrame, bounds: pd.DataFrame | None = None) -> pd.DataFrame:
    """The page's opening table: one row per estimator, one column per scenario, each cell
    "coverage · failure rate · width / exact" (text; the numbers are in the folded tables): the
    :data:`COVERAGE` (for a guaranteed set, with the replicates where its bound was broken), the
    failure rate over the scenario's replicates (``bounds``, from :func:`scenario_bounds`), the
    median width over the exact width; in words why a number does not exist (an estimator that
    failed in every replicate, no exact width because the exact set is empty, ...)."""
    s = summary.assign(row=_row_label(summary))
    cells = {}
    for _, r in s.iterrows():
        b = bounds.loc[r["scenario"]] if bounds is not None and r["scenario"] in bounds.index else None
        cells[(r["row"], r["scenario"])] = _cell(r, b)
    rows, cols = list(dict.fromkeys(s["row"])), list(dict.fromkeys(s["scenario"]))
    return pd.DataFrame([[cells.get((r, c), "not run in this scenario") for c in cols] for r in rows],
                        index=pd.Index(rows, name="estimator"), columns=cols)


def _why_none(r) -> str | None:
    """Why a summary row has no numbers at all (words), or None when it has some."""
    if r["kind"] == "failed":
        return "failed in every replicate"
    if r["kind"] == "exact" and r.get("empty_replicates", 0) == r["replicates"]:
        return "the exact set is empty in every replicate"
    return None


def coverage_table(summary: pd.DataFrame, bounds: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per scenario x estimator x regression (text): kind, level, replicates, failed, the bound at
    the truth (held in how many of the completed replicates), the :data:`COVERAGE` and the same over
    the replicates where the bound held; in words where a number cannot exist."""
    rows = []
    for _, r in summary.iterrows():
        done = int(r["replicates"] - r["failed"])
        why = _why_none(r)
        if r["kind"] == "statistical":
            level, held, cov_held = f"{100.0 * r['level']:g} %", "no bound (a confidence set)", "no bound"
        elif r["kind"] in ("guaranteed", "exact"):
            level = "none: a guaranteed set" if r["kind"] == "guaranteed" else "none: the exact feasible set"
            held = f"{int(r['bound_held_replicates'])} of {done}"
            cov_held = (f"{r['contains_truth_bound_held_pct']:.4g}" if np.isfinite(r["contains_truth_bound_held_pct"])
                        else "bound never held")
        else:
            level = held = cov_held = why or f"none: a {r['kind']} estimate"
        cov = f"{r['contains_truth_pct']:.4g}" if np.isfinite(r["contains_truth_pct"]) else (
            why or "no set (a point estimate)")
        rows.append({"kind": r["kind"], "level": level, "replicates": int(r["replicates"]),
                     "failed": int(r["failed"]), "bound held at the truth": held, "coverage [%]": cov,
                     "coverage where the bound held [%]": cov_held})
    out = pd.DataFrame(rows, index=_keyed(summary, KEYS).index)
    return out


def accuracy_table(summary: pd.DataFrame, bounds: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per scenario x estimator x regression (text): width over the exact width, |bias| and RMSE in %
    of the truth, time per replicate; in words where a number cannot exist."""
    rows = []
    for _, r in summary.iterrows():
        why = _why_none(r)
        b = bounds.loc[r["scenario"]] if bounds is not None and r["scenario"] in bounds.index else None

        def num(column: str, fmt: str = "{:.4g}", row=r, why=why) -> str:
            return fmt.format(row[column]) if np.isfinite(row[column]) else (why or "no truth to compare with")

        width = num("width_ratio_median") if np.isfinite(r["width_ratio_median"]) or why else _no_width(b)
        rows.append({"width / exact (median)": width, "|bias| [% of truth]": num("bias_rel_pct"),
                     "RMSE [% of truth]": num("rmse_rel_pct"), "time per replicate [s]": num("time_s")})
    return pd.DataFrame(rows, index=_keyed(summary, KEYS).index)


def _mask_numbers(message: str) -> str:
    """A failure message with its numbers replaced by "#", so runs failing the same way group together."""
    return re.sub(r"[-+]?\d+(\.\d+)?([eE][-+]?\d+)?", "#", message)


def failure_groups(table: pd.DataFrame) -> pd.DataFrame:
    """Failed estimator runs grouped by message (numbers masked): runs, estimators, scenarios, one
    example message; most frequent first."""
    fails = table[table["kind"] == "failed"].drop_duplicates(["scenario", "replicate", "estimator", "regression"])
    if fails.empty:
        return pd.DataFrame(columns=["runs", "estimators", "scenarios", "example"])
    fails = fails.assign(message=fails["failure"].astype(str).map(_mask_numbers),
                         who=fails["estimator"] + " / " + fails["regression"])
    out = fails.groupby("message", sort=False).agg(
        runs=("replicate", "size"), estimators=("who", lambda x: ", ".join(dict.fromkeys(x))),
        scenarios=("scenario", lambda x: ", ".join(dict.fromkeys(x))), example=("failure", "first"))
    return out.sort_values("runs", ascending=False, kind="stable")


def _spread(values: dict[str, float]) -> str:
    """"2 % of replicates" when every estimator has it, else "0–5 % of replicates (A 0 %, B 5 %)"."""
    vals = list(values.values())
    if min(vals) == max(vals):
        return f"{_pct(vals[0])} of replicates"
    return (f"{min(vals):.3g}–{_pct(max(vals))} of replicates ("
            + ", ".join(f"{k} {_pct(v)}" for k, v in values.items()) + ")")


def findings(summary: pd.DataFrame, table: pd.DataFrame) -> tuple[list[str], bool]:
    """The sentences of the findings box, computed from the summary and the replicate table, and
    whether they report a problem: a scenario whose bound is broken at the truth (its guaranteed
    sets carry no guarantee there: the first sentences, with the rate and the coverage), or a
    guaranteed set that missed the truth although its bound held (a bug)."""
    out, attention = [], False
    bounds = scenario_bounds(table)
    g = summary[summary["kind"] == "guaranteed"]
    held_all = []  # scenarios whose bound held at the truth in every replicate
    for sc, b in bounds.iterrows():
        gs = g[g["scenario"] == sc]
        contain = {r.estimator: r.contains_truth_pct for r in gs.itertuples() if np.isfinite(r.contains_truth_pct)}
        bound = f"the bound e_max = {b['bound']}" if b["bound"] else "the error bound e_max"
        if b["checked"] and b["broken"]:
            attention = True
            text = (f"{sc}: {bound} is broken at the truth in {_pct(100.0 * b['broken'] / b['checked'])} of "
                    f"replicates ({b['broken']} of {b['checked']}), so no set is guaranteed to contain it")
            if contain:
                text += f"; the guaranteed sets contain the truth in {_spread(contain)}"
            if b["exact_empty"]:
                text += (f"; the data contradict the bound (the exact feasible set is empty) in {b['exact_empty']} "
                         f"of {b['replicates']}")
            out.append(text + ".")
        elif not b["checked"]:  # no exact stage: each guaranteed set's own bound
            broken = {r.estimator: r.replicates - r.failed - r.bound_held_replicates for r in gs.itertuples()}
            if any(v > 0 for v in broken.values()):
                attention = True
                text = (f"{sc}: the errors exceed the bound in some replicates, where no set is guaranteed to "
                        "contain the truth (" + ", ".join(f"{r.estimator} {int(broken[r.estimator])} of "
                                                         f"{int(r.replicates - r.failed)}" for r in gs.itertuples())
                        + ")")
                if contain:
                    text += f"; the guaranteed sets contain the truth in {_spread(contain)}"
                out.append(text + ".")
        elif b["checked"] == b["replicates"]:
            held_all.append(sc)
    bounded = summary[summary["kind"].isin(["guaranteed", "exact"])]
    cov = bounded["contains_truth_bound_held_pct"]
    bad = bounded[cov.notna() & (cov < 100.0)]
    if len(bad):
        attention = True
        out.append("A guaranteed set missed the truth although the errors respected its bound (a bug): "
                   + "; ".join(f"{r.estimator} in {r.scenario}, contains it in {r.contains_truth_bound_held_pct:.4g} "
                               "% of those replicates" for r in bad.itertuples()) + ".")
    if held_all:
        gh = g[g["scenario"].isin(held_all)]
        words = ", ".join(held_all)
        if len(gh):
            worst = dict(gh.groupby("estimator", sort=False)["contains_truth_pct"].min())
            where = ("in every replicate" if min(worst.values()) == 100.0
                     else f"in {_spread(worst)}, in the scenario where they do least")
            out.append(f"The bound holds at the truth in every replicate of {words}: there the guaranteed sets "
                       f"({', '.join(worst)}) contain the truth {where}.")
        else:
            out.append(f"The bound holds at the truth in every replicate of {words}.")
    w = g[g["width_ratio_median"].notna()]
    if len(w):
        spans = [(lab, v.min(), v.max()) for lab, v in w.groupby("estimator", sort=False)["width_ratio_median"]]
        out.append("Guaranteed sets over the exact LP width (median per scenario): "
                   + ", ".join(f"{lab} {lo:.3g}" + (f"–{hi:.3g}" if hi != lo else "") for lab, lo, hi in spans)
                   + ".")
    st = summary[(summary["kind"] == "statistical") & summary["contains_truth_pct"].notna()]
    if len(st):
        out.append("Confidence sets: coverage against the nominal level: "
                   + "; ".join(f"{lab} {v['contains_truth_pct'].min():.3g}–{v['contains_truth_pct'].max():.3g} % "
                               f"(nominal {100.0 * v['level'].iloc[0]:g} %)"
                               for lab, v in st.groupby("estimator", sort=False)) + ".")
    groups = failure_groups(table)
    if len(groups):
        runs = table.drop_duplicates(["scenario", "replicate", "estimator", "regression"])
        out.append(f"{int(groups['runs'].sum())} of {len(runs)} estimator runs failed, {len(groups)} distinct "
                   f"message(s); most frequent: {groups['estimators'].iloc[0]}, {int(groups['runs'].iloc[0])} runs "
                   "(see Failures).")
    else:
        out.append("No estimator failed.")
    return out, attention


def campaign_page(result: CampaignResult) -> Page:
    """Build the summary page of ``result`` (nothing written): the findings and one small table
    (coverage, failure rate, width per estimator x scenario) first, failures grouped by message,
    then the details folded; each estimator in its method's style."""
    with method_styles(study_styles(result.config)):
        return _page(result)


def _page(result: CampaignResult) -> Page:
    table = result.table
    if table.empty:
        raise InputError(f"campaign {result.out} holds no completed replicate: nothing to report.")
    cfg = result.config
    if "exact_bound" not in table and np.isscalar(cfg.exact.e_max):  # files written before it was recorded
        table = table.assign(exact_bound=f"{cfg.exact.e_max:g}")
    summary = summarize(table)
    bounds = scenario_bounds(table)
    reps = table.drop_duplicates(["scenario", "replicate"])
    setup = {"study": f"{cfg.name} ({Path(cfg.file).name}), seed {cfg.seed}",
             "replicates": ", ".join(f"{s}: {n}" for s, n in reps.groupby("scenario", sort=False).size().items()),
             "mode": "campaign mode: no SDP ellipsoids, no validation experiment; exact LP bounds kept",
             "time per replicate": f"{reps['replicate_time_s'].mean():.3g} s (mean, one worker)",
             "this run": f"{len(result.computed)} computed, {len(result.skipped)} already done, "
                         f"{result.elapsed_s:.1f} s with {result.workers or 'no'} Dask workers"}
    n_reps = reps.groupby("scenario", sort=False).size()
    descr = (f"Monte Carlo campaign of the study {cfg.name}: every estimator on fresh noise in each replicate, "
             f"{n_reps.min()}" + (f"-{n_reps.max()}" if n_reps.max() != n_reps.min() else "")
             + f" replicates of each of {len(result.scenarios)} scenarios ("
             + ", ".join(sc.name for sc in result.scenarios) + "); the scenarios and the set-up are described in "
             "the last section.")
    study_page = Path(result.out).parent / "index.html"
    trail = [(f"study {cfg.name}", "../index.html")] if study_page.is_file() else []
    page = Page(f"Monte Carlo campaign: {cfg.title}", descr, home="../../index.html", trail=trail)
    page.attach(f"{DATA_DIR}/index.html", f"{DATA_DIR}/index.html",
                f"the list of the replicate files (Parquet), one per scenario and replicate, in {DATA_DIR}/")
    sentences, attention = findings(summary, table)
    page.findings(sentences, attention=attention)

    page.section("Summary", "Coverage, the one definition used on this whole page (tables, figure, findings): "
                            f"{COVERAGE}.")
    table1 = overview(summary, bounds)
    for k in range(0, table1.shape[1], MAX_SCENARIOS_PER_TABLE):  # at most 4 scenarios side by side: no scrolling
        part = table1.iloc[:, k:k + MAX_SCENARIOS_PER_TABLE]
        split = table1.shape[1] > part.shape[1]
        more = f" (scenarios {k + 1}-{k + part.shape[1]} of {table1.shape[1]})" if split else ""
        page.table(part, "Each cell: coverage · failure rate · median width / exact LP width" + more
                   + ".", name="overview" + (f"-{k // MAX_SCENARIOS_PER_TABLE + 1}" if more else ""))
    page.text("A guaranteed set must contain the truth in every replicate whose equation errors respect its bound "
              "(max |y - w^T theta_true| <= e_max): where the cell says the bound was broken, no guarantee "
              "applies and its coverage may fall below 100 %; below 100 % in the other replicates is a bug (the "
              "findings check it). A confidence set is read against its nominal level. Failure rate: share of "
              "the scenario's replicates where the estimator failed. Width: 1 is the exact feasible set; below 1 "
              "only a confidence set can be; 'no width (exact set empty)': the data contradict the bound in every "
              "replicate, so there is no exact width to divide by. 'Set empty' (LP exact): the data contradict "
              "the bound, no parameter vector fits them.")

    groups = failure_groups(table)
    if len(groups):
        page.section("Failures", "Estimators that failed on a replicate, grouped by message (numbers in the message "
                                 "replaced by #); a failure is reported, never replaced by another answer.")
        for g in groups.itertuples():
            page.text(f"{g.runs} run{'s' * (g.runs > 1)} ({g.estimators}; scenarios {g.scenarios}): {g.example}")

    page.section("Coverage of the truth", folded="Coverage per scenario and estimator: table and figure",
                 text="Coverage as defined under Summary, over each estimator's completed replicates, and for a "
                      "guaranteed set (and the exact one) also over the replicates whose errors respected its bound "
                      "(max |y - w^T theta_true| <= e_max): anything below 100 % there is a bug. Confidence sets "
                      "should reach their nominal level.")
    page.table(coverage_table(summary, bounds), "Coverage of the truth per scenario and estimator.", name="coverage")
    nominal = summary["level"].dropna()
    page.figure(_grouped_bars(summary, "contains_truth_pct", "coverage [%]",
                              reference=100.0 * nominal.iloc[0] if len(nominal) else None,
                              reference_label=f"nominal {100.0 * nominal.iloc[0]:g} %" if len(nominal) else ""),
                "Coverage per scenario, as in the table (bars: estimator / regression; no bar: no set, or "
                "failed in every replicate).", name="coverage_bars")

    page.section("Width, bias and RMSE", folded="Width over the exact width, bias, RMSE and time: tables and figures",
                 text="Width: median over replicates and parameters of the interval width over the exact LP width of "
                 "the same replicate (1 = exact; below 1 a set narrower than the feasible set, which a confidence "
                 "interval may be). Bias and RMSE: mean over the parameters of |mean(centre - truth)| and "
                 "sqrt(mean((centre - truth)^2)) relative to |truth|.")
    page.table(accuracy_table(summary, bounds), "Width over the exact width, bias, RMSE and estimator time per "
               "replicate.", name="accuracy")
    if summary["width_ratio_median"].notna().any():
        page.figure(_grouped_bars(summary[summary["kind"] != "exact"], "width_ratio_median", "width / exact width",
                                  log=True, reference=1.0, reference_label="LP exact (= 1)"),
                    "Median interval width over the exact LP width.", name="width_ratio")
    page.figure(_grouped_bars(summary, "rmse_rel_pct", "RMSE [% of |truth|]", log=True),
                "RMSE of the centres relative to the truth (mean over parameters).", name="rmse")
    page.table(_keyed(parameter_errors(table), KEYS + ["parameter"]), "Bias and RMSE per parameter (parameter units).",
               name="parameter_errors")
    fails = table[table["kind"] == "failed"].drop_duplicates(["scenario", "replicate", "estimator", "regression"])
    if len(fails):
        page.section("Failed runs", folded=f"All {len(fails)} failed estimator runs, one row each",
                     text="The failures grouped by message (numbers masked), then every failed estimator run "
                          "with its scenario, replicate and full message.")
        page.table(groups.reset_index(drop=True).set_index("example")[["runs", "estimators", "scenarios"]],
                   "Failures grouped by message (one example message per group).", name="failure_groups")
        page.table(_keyed(fails, ["scenario", "replicate", "estimator", "regression"])[["failure"]],
                   "Failed estimator runs.", name="failures")
    page.section("Scenarios and set-up", folded="The scenarios, the study and this run",
                 text="\n\n".join(f"{sc.name}: {sc.description or 'the study as written'}" for sc in result.scenarios))
    page.table(pd.DataFrame({"value": list(setup.values())}, index=pd.Index(list(setup), name="set-up")),
               "Set-up of the campaign.", name="setup")
    return page


def data_index(result: CampaignResult) -> str:
    """The page ``<out>/data/index.html``: every replicate file of the folder, linked, with its
    scenario, replicate and configuration hash and whether the campaign page counts it (files of
    another configuration, or beyond the replicates asked for, stay in the folder unread)."""
    data = Path(result.out) / DATA_DIR
    used = set(zip(result.table["scenario"], result.table["replicate"].astype(int), result.table["config_hash"],
                   strict=True)) if len(result.table) else set()
    rows = []
    for f in sorted(data.glob("*.parquet")) + sorted(data.glob("*.corrupt")):
        m = re.fullmatch(r"(.+)__([0-9a-f]+)__r(\d+)\.parquet", f.name)
        if m is None:
            rows.append((f.name, "", "", "", "no: set aside, it could not be read back"))
            continue
        sc, chash, rep = m.group(1), m.group(2), int(m.group(3))
        rows.append((f.name, sc, str(rep), chash, "yes" if (sc, rep, chash) in used else
                     "no: another configuration of the study, or a replicate beyond those asked for"))
    body = "".join(f'<tr><td><a href="{html.escape(n)}">{html.escape(n)}</a></td><td>{html.escape(sc)}</td>'
                   f"<td>{rep}</td><td>{chash}</td><td>{html.escape(used_)}</td></tr>"
                   for n, sc, rep, chash, used_ in rows)
    cfg = result.config
    title = f"Replicate files of the campaign {cfg.name}"
    trail = ([(f"study {cfg.name}", "../../index.html")] if (Path(result.out).parent / "index.html").is_file()
             else []) + [("campaign", "../index.html")]
    text = (f"<h1>{html.escape(title)}</h1><p>{len(rows)} files in this folder, one per scenario and replicate: "
            "the rows of every estimator in that replicate (Parquet; read with <code>pandas.read_parquet</code>). "
            'The <a href="../index.html">campaign page</a> is computed from the files marked "yes".</p>'
            '<div class="scroll"><table class="data"><thead><tr><th>file</th><th>scenario</th><th>replicate</th>'
            f"<th>configuration</th><th>on the campaign page</th></tr></thead><tbody>{body}</tbody></table></div>")
    return render_page(title, text, description=f"{len(rows)} replicate files of the campaign {cfg.name}.",
                       header=site_header(title, "../../../index.html", trail))


def write_campaign_page(result: CampaignResult) -> Path:
    """Write ``<out>/index.html`` (with tables/, figures/, summary.md) and ``<out>/data/index.html``
    (the replicate files, :func:`data_index`: the page links it, never the bare folder); returns the
    page path.

    The folder is replaced as a whole (:func:`boundid.report.output.replace_folder`), its ``data/``
    (the replicate files) carried over: a kill while writing leaves the previous page as it was.
    """
    page = campaign_page(result)
    (Path(result.out) / DATA_DIR).mkdir(parents=True, exist_ok=True)
    write_file_atomically(Path(result.out) / DATA_DIR / "index.html", data_index(result))
    with replace_folder(result.out, keep=(DATA_DIR,)) as tmp:
        page.write(tmp / "index.html")
    return Path(result.out) / "index.html"
