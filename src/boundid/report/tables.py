"""Comparison tables: numeric pandas DataFrames for CSV, formatted text for HTML/Markdown/LaTeX.

A table is built once as a *numeric* DataFrame (what goes to CSV). An interval column ``label``
is stored as two numeric columns ``"label lo"`` and ``"label hi"`` and recorded in
``df.attrs["intervals"] = {label: (lo_column, hi_column)}``; :func:`format_frame` turns each such
pair back into one ``"[lo, hi]"`` text column for the HTML page, ``summary.md`` and LaTeX.
LaTeX and Markdown are written by ``tabulate`` (a declared dependency); pandas' own ``to_latex``
would need jinja2, which boundid does not declare.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from tabulate import LATEX_ESCAPE_RULES, tabulate

from boundid.errors import InputError

INTERVALS = "intervals"  # key of DataFrame.attrs holding {label: (lo_column, hi_column)}
FloatFormat = str | Callable[[float], str]


def _formatter(float_format: FloatFormat) -> Callable[[float], str]:
    """``"{:.4g}"``, ``".4g"`` or a callable -> a callable; NaN prints as an en dash."""
    if callable(float_format):
        fmt = float_format
    elif "{" in float_format:
        fmt = float_format.format
    else:
        def fmt(v: float) -> str:
            return format(v, float_format)
    return lambda v: "–" if v is None or (isinstance(v, float) and np.isnan(v)) else fmt(v)


def _values(v, p: int, label: str) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.shape not in ((p,), (2, p)):
        raise InputError(f"column {label!r} must be (p,) values or a (lo, hi) pair of (p,) arrays with p = {p}, "
                         f"got shape {a.shape}.")
    if a.shape == (2, p) and np.any(a[0] > a[1]):
        raise InputError(f"column {label!r}: an interval has lo > hi.")
    return a


def parameter_table(
    names: Sequence[str],
    columns: Mapping[str, object],
    *,
    index_name: str = "parameter",
) -> pd.DataFrame:
    """One row per parameter, one column (or lo/hi pair) per entry of ``columns``.

    names : p parameter names (the index)
    columns : {label: (p,) values, or (lo (p,), hi (p,)) intervals}, e.g.
        ``{"truth": theta, "OBE-factorized": est.intervals, "LP exact": (lo, hi)}``
    Returns the numeric DataFrame (intervals as ``"label lo"``/``"label hi"`` columns, recorded in
    ``attrs["intervals"]``); render it with :func:`format_frame`.
    """
    p = len(names)
    data: dict[str, np.ndarray] = {}
    intervals: dict[str, tuple[str, str]] = {}
    for label, v in columns.items():
        a = _values(v, p, label)
        if a.ndim == 1:
            data[label] = a
        else:
            lo, hi = f"{label} lo", f"{label} hi"
            data[lo], data[hi] = a[0], a[1]
            intervals[label] = (lo, hi)
    df = pd.DataFrame(data, index=pd.Index(list(names), name=index_name))
    df.attrs[INTERVALS] = intervals
    return df


def widths(names: Sequence[str], intervals: Mapping[str, tuple[object, object]]) -> pd.DataFrame:
    """Interval widths hi - lo, one row per parameter, one column per estimate (input of
    :func:`boundid.report.figures.width_ratios`)."""
    p = len(names)
    return pd.DataFrame(
        {label: np.diff(_values(iv, p, label).reshape(2, p), axis=0)[0] for label, iv in intervals.items()},
        index=pd.Index(list(names), name="parameter"),
    )


def deviation_percent(estimates: Mapping[str, object], truth, names: Sequence[str] | None = None) -> pd.DataFrame:
    """100 (theta_hat - theta_true) / |theta_true| per parameter and estimate [%].

    estimates : {label: (p,) centre, or an object with ``.center`` (an Estimate)}
    truth : (p,) true values; a zero true value gives NaN (a relative deviation is undefined).
    """
    truth = np.asarray(truth, dtype=float)
    if truth.ndim != 1:
        raise InputError(f"truth must be (p,), got shape {truth.shape}.")
    p = truth.shape[0]
    names = list(names) if names is not None else [f"theta{j + 1}" for j in range(p)]
    if len(names) != p:
        raise InputError(f"{len(names)} names for {p} parameters.")
    scale = np.where(truth != 0.0, np.abs(truth), np.nan)
    data = {}
    for label, est in estimates.items():
        c = np.asarray(getattr(est, "center", est), dtype=float)
        if c.shape != (p,):
            raise InputError(f"estimate {label!r} has shape {c.shape}, truth ({p},).")
        data[label] = 100.0 * (c - truth) / scale
    return pd.DataFrame(data, index=pd.Index(names, name="parameter"))


def estimate_summary(estimates: Mapping[str, object], truth=None, reference: tuple | None = None) -> pd.DataFrame:
    """One row per estimate: kind, level, ln vol, ln vol / p, mean width, truth containment, outliers, time.

    estimates : {label: Estimate}
    truth : (p,) or None -> columns "truth in set" (the estimate's set, any family) and "truth in intervals"
    reference : (lo, hi) exact LP bounds or None -> column "mean width / exact"
        (mean over parameters of width / exact width).
    """
    rows = {}
    for label, e in estimates.items():
        lo, hi = (np.asarray(b, dtype=float) for b in e.intervals)
        logv = e.set.log_volume() if e.set is not None else np.nan
        row = {
            "kind": e.kind,
            "level": e.level if e.level is not None else np.nan,
            "ln vol": logv,
            "ln vol / p": logv / e.p,
            "mean width": float(np.mean(hi - lo)),
        }
        if reference is not None:
            rlo, rhi = (np.asarray(b, dtype=float) for b in reference)
            row["mean width / exact"] = float(np.mean((hi - lo) / (rhi - rlo)))
        if truth is not None:
            th = np.asarray(truth, dtype=float)
            listed = np.isfinite(th)
            if listed.all():
                row["truth in set"] = "yes" if e.contains(th) else ("no" if e.set is not None else "–")
                row["truth in intervals"] = "yes" if bool(np.all((lo <= th) & (th <= hi))) else "no"
            else:  # reference values of some parameters only: no whole vector, count their intervals
                inside = f"{int(np.sum(((lo <= th) & (th <= hi))[listed]))} of {int(listed.sum())} intervals"
                row["truth in set"] = row["truth in intervals"] = inside
        row["outliers"] = int(np.asarray(e.outliers).size)
        row["time [s]"] = float(e.time_s)
        rows[label] = row
    return pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate")


def format_frame(df: pd.DataFrame, float_format: FloatFormat = "{:.4g}") -> pd.DataFrame:
    """A text DataFrame for display: interval pairs merged into ``"[lo, hi]"``, floats formatted."""
    fmt = _formatter(float_format)
    pairs = df.attrs.get(INTERVALS, {})
    lo_of = {lo: (label, hi) for label, (lo, hi) in pairs.items()}
    his = {hi for _, hi in pairs.values()}
    out = {}
    for col in df.columns:
        if col in lo_of:
            label, hi = lo_of[col]
            out[label] = [f"[{fmt(a)}, {fmt(b)}]" for a, b in zip(df[col], df[hi], strict=True)]
        elif col not in his:
            s = df[col]
            floats = pd.api.types.is_float_dtype(s)
            out[str(col)] = [fmt(v) for v in s.astype(float)] if floats else s.astype(str).tolist()
    res = pd.DataFrame(out, index=df.index.astype(str))
    res.index.name = df.index.name
    return res


def shows_index(df: pd.DataFrame) -> bool:
    """Whether the index is content (named, or not a plain 0..n-1 range) and is written out."""
    return df.index.name is not None or not isinstance(df.index, pd.RangeIndex)


def _align(df: pd.DataFrame) -> tuple[str, ...]:
    """Index left, value columns right (the display frame is all text, so tabulate cannot tell)."""
    return ("left",) * shows_index(df) + ("right",) * len(format_frame(df).columns)


def markdown_table(df: pd.DataFrame, float_format: FloatFormat = "{:.4g}") -> str:
    """The table in GitHub Markdown (``DataFrame.to_markdown``, i.e. tabulate)."""
    return format_frame(df, float_format).to_markdown(index=shows_index(df), disable_numparse=True,
                                                      colalign=_align(df))


def latex_table(df: pd.DataFrame, caption: str | None = None, label: str | None = None,
                float_format: FloatFormat = "{:.4g}") -> str:
    """A booktabs LaTeX ``table`` (tabulate's ``latex_booktabs``; special characters escaped)."""
    text = format_frame(df, float_format)
    body = tabulate(text, headers="keys", tablefmt="latex_booktabs", showindex=shows_index(df),
                    disable_numparse=True, colalign=_align(df))
    lines = ["\\begin{table}[htbp]", "\\centering"]
    if caption:
        lines.append("\\caption{" + "".join(LATEX_ESCAPE_RULES.get(ch, ch) for ch in caption) + "}")
    if label:
        lines.append(f"\\label{{{label}}}")
    lines += [body, "\\end{table}", ""]
    return "\n".join(lines)
