"""The summary page of a Monte Carlo campaign: coverage of the truth, width over the exact width,
bias and RMSE, time per replicate, per estimator and scenario.

The page opens with its findings (computed sentences) and one small table, estimator x scenario,
each cell "coverage · failure rate · width / exact" (:func:`overview`); failures follow, grouped by
message with counts (:func:`failure_groups`); every other table and figure is folded (<details>).

Every number is computed from the campaign's Parquet files (``<out>/data/``); the page is
written to ``<out>/index.html`` with its tables and figures beside it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from boundid.errors import InputError
from boundid.report.figures import DPI, color_for, method_styles
from boundid.report.html import Page
from boundid.report.output import replace_folder
from boundid.studies.campaign import DATA_DIR, CampaignResult, parameter_errors, summarize

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
    return "–" if not np.isfinite(x) else f"{x:.3g} %"


def _row_label(summary: pd.DataFrame) -> pd.Series:
    """"estimator", or "estimator / regression" when the campaign has several regressions."""
    several = summary["regression"].nunique() > 1
    return summary["estimator"] + (" / " + summary["regression"] if several else "")


def coverage_shown(row) -> float:
    """The coverage a reader judges: a guaranteed set's over the replicates whose errors respected
    its bound (must be 100 %), any other set's over all replicates (against its nominal level)."""
    return row["coverage_bound_held_pct"] if row["kind"] == "guaranteed" else row["coverage_pct"]


def overview(summary: pd.DataFrame) -> pd.DataFrame:
    """The page's opening table: one row per estimator, one column per scenario, each cell
    "coverage · failure rate · width / exact" (text; the numbers are in the folded tables); "no
    result" where the scenario has no row of that estimator (the exact LP bounds of data that
    contradict the bound)."""
    s = summary.assign(row=_row_label(summary))
    cells = {}
    for _, r in s.iterrows():
        fail = 100.0 * r["failed"] / r["replicates"] if r["replicates"] else np.nan
        width = "–" if not np.isfinite(r["width_ratio_median"]) else f"{r['width_ratio_median']:.3g}"
        cells[(r["row"], r["scenario"])] = f"{_pct(coverage_shown(r))} · {_pct(fail)} · {width}"
    rows, cols = list(dict.fromkeys(s["row"])), list(dict.fromkeys(s["scenario"]))
    return pd.DataFrame([[cells.get((r, c), "no result") for c in cols] for r in rows],
                        index=pd.Index(rows, name="estimator"), columns=cols)


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


def findings(summary: pd.DataFrame, table: pd.DataFrame) -> tuple[list[str], bool]:
    """The sentences of the findings box, computed from the summary and the replicate table, and
    whether they report a problem (a guaranteed set that missed the truth although its bound held)."""
    out, attention = [], False
    g = summary[summary["kind"] == "guaranteed"]
    if len(g):
        held = g["coverage_bound_held_pct"]
        bad = g[held.notna() & (held < 100.0)]
        if len(bad):
            attention = True
            out.append("A guaranteed set missed the truth although the errors respected its bound (a bug): "
                       + "; ".join(f"{r.estimator} in {r.scenario}, {r.coverage_bound_held_pct:.4g} %"
                                   for r in bad.itertuples()) + ".")
        elif held.notna().any():
            out.append(f"Every guaranteed set ({', '.join(dict.fromkeys(g['estimator']))}) contained the truth in "
                       "every replicate whose errors respected its bound.")
        never = g[(g["bound_held_replicates"] < g["replicates"] - g["failed"])]
        if len(never):
            parts = []
            for scenario, rows in never.groupby("scenario", sort=False):
                counts = {f"{int(r.bound_held_replicates)} of {int(r.replicates - r.failed)}"
                          for r in rows.itertuples()}
                if len(counts) == 1:  # the same rows bound every estimator: say it once
                    parts.append(f"{scenario}: bound held in {counts.pop()} replicates")
                else:
                    parts.append(f"{scenario}: " + ", ".join(
                        f"{r.estimator} {int(r.bound_held_replicates)} of {int(r.replicates - r.failed)}"
                        for r in rows.itertuples()))
            out.append("The errors exceeded the bound in some replicates, where no guarantee applies: "
                       + "; ".join(parts) + ".")
        w = g[g["width_ratio_median"].notna()]
        if len(w):
            spans = [(lab, v.min(), v.max()) for lab, v in w.groupby("estimator", sort=False)["width_ratio_median"]]
            out.append("Guaranteed sets over the exact LP width (median per scenario): "
                       + ", ".join(f"{lab} {lo:.3g}" + (f"–{hi:.3g}" if hi != lo else "") for lab, lo, hi in spans)
                       + ".")
    st = summary[summary["kind"] == "statistical"]
    if len(st):
        out.append("Confidence sets: coverage of the truth against the nominal level: "
                   + "; ".join(f"{lab} {v['coverage_pct'].min():.3g}–{v['coverage_pct'].max():.3g} % "
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
    with method_styles(result.config.styles()):
        return _page(result)


def _page(result: CampaignResult) -> Page:
    table = result.table
    if table.empty:
        raise InputError(f"campaign {result.out} holds no completed replicate: nothing to report.")
    cfg = result.config
    summary = summarize(table)
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
    page.attach("data/", "data/", f"the replicate files (Parquet), one per scenario and replicate ({DATA_DIR}/)")
    sentences, attention = findings(summary, table)
    page.findings(sentences, attention=attention)

    page.section("Summary")
    table1 = overview(summary)
    for k in range(0, table1.shape[1], MAX_SCENARIOS_PER_TABLE):  # at most 4 scenarios side by side: no scrolling
        part = table1.iloc[:, k:k + MAX_SCENARIOS_PER_TABLE]
        split = table1.shape[1] > part.shape[1]
        more = f" (scenarios {k + 1}-{k + part.shape[1]} of {table1.shape[1]})" if split else ""
        page.table(part, "Each cell: coverage of the truth · failure rate · median width / exact LP width" + more
                   + ".", name="overview" + (f"-{k // MAX_SCENARIOS_PER_TABLE + 1}" if more else ""))
    page.text("Coverage is the share of per-parameter intervals lo <= truth <= hi: for a guaranteed set over the "
              "replicates whose equation errors respected its bound (anything below 100 % is a bug), for a "
              "confidence set over all replicates (to be read against its nominal level). Failure rate: share of "
              "the replicates where the estimator failed. Width: 1 is the exact feasible set; below 1 only a "
              "confidence set can be.")

    groups = failure_groups(table)
    if len(groups):
        page.section("Failures", "Estimators that failed on a replicate, grouped by message (numbers in the message "
                                 "replaced by #); a failure is reported, never replaced by another answer.")
        for g in groups.itertuples():
            page.text(f"{g.runs} run{'s' * (g.runs > 1)} ({g.estimators}; scenarios {g.scenarios}): {g.example}")

    page.section("Coverage of the truth", folded="Coverage per scenario and estimator: table and figure",
                 text="Share of the per-parameter intervals lo <= truth <= hi over all replicates. A guaranteed set "
                      "must contain the truth whenever the equation errors respect its bound (column 'coverage when "
                      "bound held', over the replicates with max |y - w^T theta_true| <= e_max): anything below "
                      "100 % there is a bug. Confidence intervals should reach their nominal level.")
    cov = _keyed(summary, KEYS)[["kind", "level", "replicates", "failed", "coverage_pct",
                   "bound_held_replicates", "coverage_bound_held_pct"]].rename(columns={
                       "coverage_pct": "coverage [%]", "coverage_bound_held_pct": "coverage when bound held [%]",
                       "bound_held_replicates": "replicates with bound held"})
    page.table(cov, "Coverage of the true parameters per scenario and estimator.", float_format="{:.4g}",
               name="coverage")
    nominal = summary["level"].dropna()
    page.figure(_grouped_bars(summary, "coverage_pct", "coverage [%]",
                              reference=100.0 * nominal.iloc[0] if len(nominal) else None,
                              reference_label=f"nominal {100.0 * nominal.iloc[0]:g} %" if len(nominal) else ""),
                "Coverage of the truth per scenario (bars: estimator / regression).", name="coverage_bars")

    page.section("Width, bias and RMSE", folded="Width over the exact width, bias, RMSE and time: tables and figures",
                 text="Width: median over replicates and parameters of the interval width over the exact LP width of "
                 "the same replicate (1 = exact; below 1 a set narrower than the feasible set, which a confidence "
                 "interval may be). Bias and RMSE: mean over the parameters of |mean(centre - truth)| and "
                 "sqrt(mean((centre - truth)^2)) relative to |truth|.")
    acc = _keyed(summary, KEYS)[["width_ratio_median", "bias_rel_pct", "rmse_rel_pct",
                   "time_s"]].rename(columns={"width_ratio_median": "width / exact (median)",
                                              "bias_rel_pct": "|bias| [% of truth]",
                                              "rmse_rel_pct": "RMSE [% of truth]", "time_s": "time per replicate [s]"})
    page.table(acc, "Width over the exact width, bias, RMSE and estimator time per replicate.", name="accuracy")
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




def write_campaign_page(result: CampaignResult) -> Path:
    """Write ``<out>/index.html`` (with tables/, figures/, summary.md); returns the page path.

    The folder is replaced as a whole (:func:`boundid.report.output.replace_folder`), its ``data/``
    (the replicate files) carried over: a kill while writing leaves the previous page as it was.
    """
    page = campaign_page(result)
    with replace_folder(result.out, keep=(DATA_DIR,)) as tmp:
        page.write(tmp / "index.html")
    return Path(result.out) / "index.html"
