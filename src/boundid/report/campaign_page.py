"""The summary page of a Monte Carlo campaign: coverage of the truth, width over the exact width,
bias and RMSE, time per replicate, per estimator and scenario.

Every number is computed from the campaign's Parquet files (``<out>/data/``); the page is
written to ``<out>/index.html`` with its tables and figures beside it.
"""

from __future__ import annotations

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


def campaign_page(result: CampaignResult) -> Page:
    """Build the summary page of ``result`` (nothing written); each estimator in its method's style."""
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
    descr = "\n\n".join(f"{sc.name}: {sc.description or 'the study as written'}" for sc in result.scenarios)
    page = Page(f"Monte Carlo campaign: {cfg.title}", descr, setup=setup)

    page.section("Coverage of the truth",
                 "Share of the per-parameter intervals lo <= truth <= hi over all replicates. A guaranteed set "
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

    page.section("Width, bias and RMSE",
                 "Width: median over replicates and parameters of the interval width over the exact LP width of "
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
        page.section("Failures", "Estimators that failed on a replicate, with the reason (never replaced by "
                                 "another answer).")
        page.table(_keyed(fails, ["scenario", "replicate", "estimator", "regression"])[["failure"]],
                   "Failed estimator runs.", name="failures")
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
