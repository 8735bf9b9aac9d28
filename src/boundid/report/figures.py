"""Figures of a study: matplotlib ``Figure`` objects built from plain arrays.

Every function takes numpy arrays, dicts of arrays or 2-D :class:`~boundid.sets.ConvexSet` objects and
returns a :class:`matplotlib.figure.Figure`. Figures are created with ``Figure()`` directly (not
``pyplot``), so they render with the Agg canvas whatever the interactive backend is, and nothing
accumulates in pyplot's figure registry. Every series has a colour, a marker and a line style
that together differ from every other series of its figure (:func:`series_styles`, from the
colour-blind-safe palette :data:`SERIES`; a study's series keep one style in every figure of its
report, :meth:`boundid.studies.config.StudyConfig.styles` through :func:`method_styles`). Legends sit
outside the axes at :data:`LEGEND_PT`, and the figure grows to hold them (nothing is cut off in the
saved image; :func:`boundid.report.figure_check.figure_problems` checks it).
"""

from __future__ import annotations

import zlib
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Polygon, Rectangle
from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

from boundid.errors import InputError
from boundid.estimators.method import Style
from boundid.sets.convex import ConvexSet

# The references drawn beside the estimators (not methods of the registry): black and greys, each
# with its own line style, so that every colour of SERIES_COLORS is left to the estimators.
REFERENCE_STYLES: dict[str, Style] = {
    "LP exact": Style("#000000", "s", "--"),
    "SDP outer": Style("#000000", "s", "-."),
    "SDP john": Style("#777777", "^", "--"),
    "SDP inner": Style("#000000", "d", ":"),
    "truth": Style("#000000", "*", "--"),
    "measured": Style("#4D4D4D", "", "-"),
}
PALETTE: dict[str, str] = {k: s.color for k, s in REFERENCE_STYLES.items()}

# The estimators' series: the Okabe-Ito colour-blind-safe colours (black, kept for the references,
# and yellow, unreadable on white, left out) and two of Paul Tol's (wine, olive), in an order that
# keeps the first few series far apart.
SERIES_COLORS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#D55E00", "#56B4E9", "#882255", "#999933")
SERIES_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<")
SERIES_LINESTYLES = ("-", "--", "-.", ":")


def series_style(k: int) -> Style:
    """The style of the k-th series (k >= 0) of the palette: colour k mod 8, line style (k // 8) mod 4,
    marker (k + k // 8) mod 8. Series k and k + 8 share a colour but neither marker nor line style;
    the first 16 series differ pairwise in colour or in both marker and line style, and the
    (colour, marker, line style) triples of the first 64 are all different."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
        raise InputError(f"series_style needs an index k >= 0, got {k!r}.")
    k = int(k)
    return Style(SERIES_COLORS[k % 8], SERIES_MARKERS[(k + k // 8) % 8], SERIES_LINESTYLES[(k // 8) % 4])


#: the palette of up to 16 series: colour, marker and line style together unique per series
SERIES: tuple[Style, ...] = tuple(series_style(k) for k in range(16))

# a label that is neither an estimator of the study in effect nor a reference (a lesson's own
# series), styled alone by style_for: a colour chosen by a CRC32 hash of the label
_FALLBACK = SERIES_COLORS
# {estimator label: Style} of the study whose figures are being drawn (method_styles)
_STYLES: ContextVar[Mapping[str, Style] | None] = ContextVar("method_styles", default=None)

DPI = 110  # PNG resolution of embedded figures: legible and small (pages stay well under 3 MB)
_AX_W, _AX_H = 3.0, 2.2  # inches per subplot (3 columns: MAX_WIDTH_IN)
LEGEND_PT = 9.0  # legend font size: >= 9 pt on the page (figures up to 9 in wide are shown at full size)
MAX_WIDTH_IN = 9.0  # a page shows 1000 px: 9 in at DPI are shown unscaled


def study_styles(cfg) -> dict[str, Style]:
    """{series label: Style} of a study (a :class:`boundid.studies.config.StudyConfig`), what the report
    draws each series with: one entry of the palette (:func:`series_style`, in the order of the study
    file) per estimator and regression model ("RLS / filtered_dynamic"), so that no two series of a
    study share colour, marker and line style (up to 64 series; the first 16 differ in colour or in
    both marker and line style); an estimator's own label takes the style of its series on the exact
    regression, else on its first regression."""
    series = [(e.label, rn) for e in cfg.estimators for rn in e.regressions]
    out = {f"{lab} / {rn}": series_style(k) for k, (lab, rn) in enumerate(series)}
    for e in cfg.estimators:
        rn = cfg.exact.regression if cfg.exact.regression in e.regressions else e.regressions[0]
        out[e.label] = out[f"{e.label} / {rn}"]
    return out


@contextmanager
def method_styles(styles: Mapping[str, Style]) -> Iterator[None]:
    """Draw the figures made inside the block with ``styles`` = {estimator label: Style}, e.g. a
    study's :meth:`~boundid.studies.config.StudyConfig.styles` (one palette entry per estimator
    and regression model, :data:`SERIES`)."""
    token = _STYLES.set(dict(styles))
    try:
        yield
    finally:
        _STYLES.reset(token)


def _named_style(label: str) -> Style | None:
    """The style :func:`method_styles` or :data:`REFERENCE_STYLES` give ``label`` (see style_for), or None."""
    for styles in (_STYLES.get() or {}, REFERENCE_STYLES):
        named = [k for k in styles if label == k or label.startswith(k + " ")]
        if named:
            return styles[max(named, key=len)]
    return None


def style_for(label: str) -> Style:
    """The style of a figure label: that of the estimator label it names (exactly, or followed by
    a space: "RLS / filtered_dynamic", "OBE-standard (unverified)", "WLS 95 %"; the longest such
    label wins) from :func:`method_styles`; a reference of :data:`REFERENCE_STYLES` (named the same way)
    its style; any other label a palette colour by the CRC32 hash of the label, the same in every
    figure. Figures with several series use :func:`series_styles`, which keeps these styles but
    never gives two series of one figure the same one."""
    named = _named_style(label)
    if named is not None:
        return named
    return Style(_FALLBACK[zlib.crc32(label.encode()) % len(_FALLBACK)], "o")


def color_for(label: str) -> str:
    """The colour of :func:`style_for` ``label``."""
    return style_for(label).color


def series_styles(labels: Sequence[str]) -> dict[str, Style]:
    """{label: Style} for the series of one figure, pairwise different in (colour, marker, line style).

    A label named by :func:`method_styles` or :data:`REFERENCE_STYLES` keeps that style (the same in every
    figure of a report) unless an earlier label of the figure already took it; the others take the
    palette entries (:func:`series_style`) in order, first those whose colour the figure does not
    use yet, then those whose triple it does not use.
    """
    out: dict[str, Style] = {}
    pending = []
    for label in labels:
        if label in out:
            continue
        st = _named_style(label)
        if st is None or st in out.values():
            pending.append(label)
        else:
            out[label] = st
    candidates = [series_style(k) for k in range(64)]
    for label in pending:
        colours = {s.color for s in out.values()}
        taken = set(out.values())
        out[label] = next((s for s in candidates if s.color not in colours),
                          next((s for s in candidates if s not in taken), candidates[len(out) % 64]))
    return {label: out[label] for label in dict.fromkeys(labels)}


def _line_kw(st: Style, n_points: int, k: int = 0, n_series: int = 1, lw: float = 1.2) -> dict:
    """plot() keywords drawing a series in ``st``: its colour and line style, and its marker every
    1/8 of the ``n_points`` (staggered by the series' place ``k`` of ``n_series``), so the marker
    tells series apart where colours do not."""
    kw = {"color": st.color, "ls": st.linestyle, "lw": lw}
    if st.marker and st.marker.lower() != "none":
        step = max(1, n_points // 8)
        kw.update(marker=st.marker, ms=4.5, markevery=(min(n_points - 1, step * k // max(n_series, 1)) if n_points
                                                       else 0, step), mec="white", mew=0.4)
    return kw


def _figure(width: float, height: float) -> Figure:
    """A constrained-layout figure at :data:`DPI` with an Agg canvas (to measure text before drawing)."""
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _fit_ncols(make, n: int, max_width_px: float, renderer):
    """The legend made by ``make(ncols)`` with the fewest rows that is at most ``max_width_px`` wide
    (rows balanced: as few columns as that many rows need); one column if none fits."""
    for rows in range(1, n + 1):
        ncols = -(-n // rows)
        if rows > 1 and ncols == -(-n // (rows - 1)):
            continue  # the same number of columns as the last try
        leg = make(ncols)
        if ncols == 1 or leg.get_window_extent(renderer).width <= max_width_px:
            return leg
        leg.remove()
    raise AssertionError("unreachable: one column is always returned")


def _figure_legend(fig: Figure, handles: list, labels: list[str], where: str = "top") -> None:
    """The legend of ``fig`` outside its axes, at :data:`LEGEND_PT`: on top (``where="top"``) in as
    many columns as the figure's width holds, the figure made taller by the legend's height so the
    axes keep theirs; or on the right (``"right"``), the figure made wider by its width (at most
    :data:`MAX_WIDTH_IN`, then the legend goes on top) and tall enough for it."""
    if not labels:
        return
    renderer = fig.canvas.get_renderer()
    if where == "right":
        leg = fig.legend(handles, labels, loc="outside right upper", fontsize=LEGEND_PT, frameon=False)
        box = leg.get_window_extent(renderer)
        width = fig.get_figwidth() + box.width / fig.dpi + 0.15
        if width <= MAX_WIDTH_IN:
            fig.set_figwidth(width)
            fig.set_figheight(max(fig.get_figheight(), box.height / fig.dpi + 0.3))
            return
        leg.remove()
    pad = 0.1 * fig.dpi
    leg = _fit_ncols(lambda c: fig.legend(handles, labels, loc="outside upper center", ncols=c,
                                          fontsize=LEGEND_PT, frameon=False, columnspacing=1.2),
                     len(labels), fig.bbox.width - 2 * pad, renderer)
    fig.set_figheight(fig.get_figheight() + leg.get_window_extent(renderer).height / fig.dpi + 0.1)


def _unique_handles(axes) -> tuple[list, list[str]]:
    """The legend entries of several axes, each label once, in order of first appearance."""
    handles: dict = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    return list(handles.values()), list(handles)


def _grid(n: int, max_cols: int = 3) -> tuple[int, int]:
    ncols = min(n, 2 if n <= 4 else max_cols)
    return -(-n // ncols), ncols


def _panel_figure(n: int, max_cols: int = 3, sharex: bool = True) -> tuple[Figure, list]:
    """A constrained-layout figure with exactly ``n`` axes in a grid (unused grid cells removed)."""
    nrows, ncols = _grid(n, max_cols)
    fig = _figure(_AX_W * ncols, _AX_H * nrows + 0.2)
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False).ravel()
    for ax in axes[n:]:
        fig.delaxes(ax)
    return fig, list(axes[:n])


def _as_columns(a, name: str, n_rows: int | None = None) -> np.ndarray:
    """(N,) or (N, n) -> float (N, n); checks finiteness-agnostic shape only."""
    x = np.asarray(a, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise InputError(f"{name} must be (N,) or (N, n), got shape {x.shape}.")
    if n_rows is not None and x.shape[0] != n_rows:
        raise InputError(f"{name} has {x.shape[0]} rows but the time vector has {n_rows} samples.")
    return x


def _trace(value, what: str) -> tuple[np.ndarray, np.ndarray]:
    """A history entry: a ``(index, values)`` pair or an object with ``.index`` and ``.<what>``."""
    if hasattr(value, "index") and hasattr(value, what):
        return np.asarray(value.index), np.asarray(getattr(value, what), dtype=float)
    index, values = value
    return np.asarray(index), np.asarray(values, dtype=float)


def _x_axis(t, index: np.ndarray) -> np.ndarray:
    """Sample indices -> times t[index] when a time vector is given, else the indices."""
    if t is None:
        return index.astype(float)
    t = np.asarray(t, dtype=float)
    if index.size and (index.min() < 0 or index.max() >= t.shape[0]):
        raise InputError(f"history index runs to {index.max()} but the time vector has only {t.shape[0]} samples.")
    return t[index.astype(int)]


def _label(name: str, unit: str | None) -> str:
    return f"{name} [{unit}]" if unit else name


def _robust_limits(values: list[np.ndarray], margin: float = 0.08) -> tuple[float, float] | None:
    finite = np.concatenate([v[np.isfinite(v)] for v in values]) if values else np.zeros(0)
    if finite.size == 0:
        return None
    lo, hi = float(finite.min()), float(finite.max())
    pad = margin * (hi - lo) if hi > lo else max(abs(lo), 1.0) * margin
    return lo - pad, hi + pad


def _stride(n: int, max_points: int) -> slice:
    """Every k-th sample so that at most ``max_points`` are drawn."""
    return slice(None, None, max(1, -(-n // max_points)))


def parameter_convergence(
    t,
    histories: Mapping[str, object],
    truth=None,
    names: Sequence[str] | None = None,
    *,
    units: Sequence[str] | None = None,
    transient: float = 0.05,
    max_points: int = 4000,
) -> Figure:
    """theta_hat against time, one subplot per parameter, one line per estimator.

    The convergence figure of the direct-drive paper: each estimator's centre after each recorded
    sample, with the true value as a dashed black line.

    t : (N,) array [s] or None
        Time of each sample; history indices are looked up in it. None plots against the index.
    histories : {label: (index (K,), centers (K, p))} or {label: History}
    truth : (p,) array or None
        True parameter values, drawn as dashed lines.
    names, units : p strings each, or None (names default to theta1..thetap).
    transient : float in [0, 1)
        The y-limits ignore the first ``transient`` fraction of each trace, so that the large
        initial swings of recursive estimators do not flatten the converged part (the lines are
        still drawn in full).
    max_points : longer traces are drawn with every k-th recorded point only (figure size).
    """
    if not histories:
        raise InputError("parameter_convergence needs at least one history.")
    if not 0.0 <= transient < 1.0:
        raise InputError(f"transient must be in [0, 1), got {transient}.")
    traces = {label: _trace(h, "centers") for label, h in histories.items()}
    p = {c.shape[1] if c.ndim == 2 else -1 for _, c in traces.values()}
    if len(p) != 1 or -1 in p:
        raise InputError(f"every history needs centers of shape (K, p) with the same p; got p in {sorted(p)}.")
    p = p.pop()
    names = list(names) if names is not None else [f"theta{j + 1}" for j in range(p)]
    truth = None if truth is None else np.asarray(truth, dtype=float)
    if len(names) != p or (truth is not None and truth.shape != (p,)):
        raise InputError(f"names and truth must have p = {p} entries.")
    fig, axes = _panel_figure(p)
    styles = series_styles(list(traces) + (["truth"] if truth is not None else []))
    for k, (label, (index, centers)) in enumerate(traces.items()):
        s = _stride(index.shape[0], max_points)
        x = _x_axis(t, index)[s]
        kw = _line_kw(styles[label], x.shape[0], k, len(traces))
        for j, ax in enumerate(axes):
            ax.plot(x, centers[s, j], label=label, **kw)
    for j, ax in enumerate(axes):
        tails = [c[int(transient * c.shape[0]) :, j] for _, c in traces.values()]
        if truth is not None:
            ax.axhline(truth[j], color=styles["truth"].color, ls=styles["truth"].linestyle, lw=1.0, label="truth")
            tails.append(truth[j : j + 1])
        limits = _robust_limits(tails)
        if limits is not None:
            ax.set_ylim(*limits)
        ax.set_ylabel(_label(names[j], units[j] if units is not None else None))
        ax.grid(alpha=0.3)
    for ax in axes[-_grid(p)[1] :]:
        ax.set_xlabel("time [s]" if t is not None else "sample")
        ax.xaxis.set_tick_params(labelbottom=True)
    _figure_legend(fig, *axes[0].get_legend_handles_labels())
    return fig


def torque_bounds(
    t,
    measured,
    lower,
    upper,
    band_label: str = "OBE bounds",
    extra_bands: Mapping[str, tuple[object, object]] | None = None,
    *,
    joint_names: Sequence[str] | None = None,
    unit: str = "N m",
    max_points: int = 4000,
) -> Figure:
    """Measured torque inside the predicted torque bounds, one subplot per joint.

    The cross-validation figure of the H4 paper (eq. 37, Fig. 4): the bounds [-h_S(-w), h_S(w)]
    of a guaranteed set S (for an ellipsoid w^T theta_hat +- sqrt(w^T M^-1 w)), filled, with the
    measured torque drawn on top; samples outside the band are marked and counted in the subplot
    title.

    t : (N,) [s];  measured, lower, upper : (N,) or (N, n) [``unit``], NaN where a joint has no
        sample (drawn as a gap, not counted)
    extra_bands : {label: (lower (N, n), upper (N, n))}, e.g. the WLS 95 % prediction band,
        drawn as outlines so both bands stay readable.
    max_points : for long records only every k-th sample is drawn so the figure stays small
        (outside-band samples are found on the full record and all marked).
    """
    t = np.asarray(t, dtype=float)
    N = t.shape[0]
    meas = _as_columns(measured, "measured", N)
    lo = _as_columns(lower, "lower", N)
    hi = _as_columns(upper, "upper", N)
    if lo.shape != meas.shape or hi.shape != meas.shape:
        raise InputError(f"measured, lower and upper must have one shape, got {meas.shape}, {lo.shape}, {hi.shape}.")
    if np.any(hi < lo):  # NaN (a joint without a row at that sample) compares False: a gap in the plot
        raise InputError("the band needs lower <= upper on every sample.")
    extra = {}
    for label, (a, b) in (extra_bands or {}).items():
        extra[label] = (_as_columns(a, f"{label} lower", N), _as_columns(b, f"{label} upper", N))
        if extra[label][0].shape != meas.shape or extra[label][1].shape != meas.shape:
            raise InputError(f"band {label!r} must have shape {meas.shape}.")
    n = meas.shape[1]
    names = list(joint_names) if joint_names is not None else [f"joint {i + 1}" for i in range(n)]
    fig = _figure(7.0, 2.0 * n + 0.3)
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    s = _stride(N, max_points)
    styles = series_styles([band_label, *extra, "measured"])
    band_color = styles[band_label].color
    for i, ax in enumerate(axes):
        ax.fill_between(t[s], lo[s, i], hi[s, i], color=band_color, alpha=0.3, lw=0, label=band_label)
        for k, (label, (a, b)) in enumerate(extra.items()):
            kw = _line_kw(styles[label], t[s].shape[0], k, len(extra), lw=0.9)
            ax.plot(t[s], a[s, i], label=label, **kw)
            ax.plot(t[s], b[s, i], **kw)
        ax.plot(t[s], meas[s, i], color=styles["measured"].color, ls=styles["measured"].linestyle, lw=0.7,
                label="measured")
        out = (meas[:, i] < lo[:, i]) | (meas[:, i] > hi[:, i])
        if out.any():
            ax.plot(t[out], meas[out, i], "x", color="#D00000", ms=4, label="outside bounds")
        rows = int(np.sum(~np.isnan(meas[:, i])))
        ax.set_title(f"{names[i]}: {int(out.sum())} of {rows} samples outside {band_label}", fontsize=9)
        ax.set_ylabel(_label("torque", unit))
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    _figure_legend(fig, *_unique_handles(axes))
    return fig


def trajectory_comparison(
    t,
    q_measured,
    q_resimulated: Mapping[str, object],
    *,
    joint_names: Sequence[str] | None = None,
    unit: str = "rad",
) -> Figure:
    """Open-loop re-simulation with identified parameters against the measured positions.

    Left column: positions per joint; right column: re-simulated minus measured, where the
    differences between estimators are visible at all. 2 n axes for n joints.

    t : (N,) [s];  q_measured : (N,) or (N, n) [``unit``];  q_resimulated : {label: (N, n)}
    """
    t = np.asarray(t, dtype=float)
    N = t.shape[0]
    qm = _as_columns(q_measured, "q_measured", N)
    sims = {label: _as_columns(q, f"q_resimulated[{label!r}]", N) for label, q in q_resimulated.items()}
    for label, q in sims.items():
        if q.shape != qm.shape:
            raise InputError(f"q_resimulated[{label!r}] has shape {q.shape}, q_measured {qm.shape}.")
    n = qm.shape[1]
    names = list(joint_names) if joint_names is not None else [f"joint {i + 1}" for i in range(n)]
    fig = _figure(8.0, 2.0 * n + 0.3)
    axes = fig.subplots(n, 2, sharex=True, squeeze=False)
    styles = series_styles(["measured", *sims])
    measured = styles["measured"]
    for i in range(n):
        ax, ax_err = axes[i]
        ax.plot(t, qm[:, i], color=measured.color, ls=measured.linestyle, lw=1.8, label="measured")
        ax_err.axhline(0.0, color=measured.color, lw=0.8)
        for k, (label, q) in enumerate(sims.items()):
            kw = _line_kw(styles[label], N, k, len(sims), lw=1.1)
            ax.plot(t, q[:, i], label=label, **kw)
            ax_err.plot(t, q[:, i] - qm[:, i], label=label, **kw)
        ax.set_ylabel(_label(f"q {names[i]}", unit))
        ax_err.set_ylabel(_label("re-sim - measured", unit))
        for a in (ax, ax_err):
            a.grid(alpha=0.3)
    for a in axes[-1]:
        a.set_xlabel("time [s]")
    _figure_legend(fig, *axes[0, 0].get_legend_handles_labels())
    return fig


#: a set shadow wider than this many times the exact shadow (on an axis) does not set the frame
FRAME_SPAN = 20.0


def projection_2d(
    polytope,
    sets: Mapping[str, ConvexSet],
    truth_2d=None,
    box=None,
    names: Sequence[str] = ("theta_i", "theta_j"),
    *,
    centers: Mapping[str, object] | None = None,
    units: Sequence[str] | None = None,
) -> Figure:
    """A parameter pair: the exact polytope's shadow with the shadows of the set estimates.

    polytope : a 2-D ConvexSet or None
        The exact shadow of the feasible polytope on the pair (``Polytope.project(i, j)``), drawn
        filled in grey.
    sets : {label: 2-D ConvexSet} (``set.project(i, j)`` of each estimate, any family), drawn by
        their ``boundary()``.
    centers : {label: (2,)} or None, the estimates' centres on the pair, marked with a dot.
    truth_2d : (2,) or None, marked with a star.
    box : (lo (2,), hi (2,)) or None, e.g. the exact LP bounds of the pair, drawn dashed.

    The limits hold the exact set, the LP box, the truth and every set but John's ellipsoid and
    those more than :data:`FRAME_SPAN` times wider than the exact shadow on an axis (a wide prior
    box would shrink everything else to a dot): these run past the frame, and their legend entry
    says so. Equal aspect where both parameters have the same unit and comparable spans (within 4:1).
    """
    fig = _figure(5.2, 4.0)
    ax = fig.subplots()
    for label, S in {"polytope": polytope, **sets}.items():
        if S is not None and S.dim != 2:
            raise InputError(f"{label}: projection_2d draws 2-D sets; project() this {S.dim}-D set on the pair first.")
    if polytope is not None:
        ax.add_patch(Polygon(polytope.boundary()[:-1], closed=True, facecolor="#BBBBBB", edgecolor="#333333",
                             alpha=0.6, lw=1.0, label="polytope (exact set)"))
    if box is not None:
        lo, hi = (np.asarray(b, dtype=float) for b in box)
        if lo.shape != (2,) or hi.shape != (2,) or np.any(hi < lo):
            raise InputError("box must be (lo (2,), hi (2,)) with lo <= hi.")
        ax.add_patch(Rectangle(tuple(lo), *(hi - lo), fill=False, ls=REFERENCE_STYLES["LP exact"].linestyle, lw=1.0,
                               edgecolor=REFERENCE_STYLES["LP exact"].color, label="LP exact bounds"))
    reference = ([polytope.boundary()] if polytope is not None else []) + ([np.array([lo, hi])] if box is not None
                                                                          else [])
    ref_span = np.ptp(np.vstack(reference), axis=0) if reference else None
    boundaries = {label: S.boundary(240) for label, S in sets.items()}
    too_wide = {label for label, b in boundaries.items() if ref_span is not None and np.all(ref_span > 0)
                and np.any(np.ptp(b, axis=0) > FRAME_SPAN * ref_span)}
    styles = series_styles(list(boundaries) + (["truth"] if truth_2d is not None else []))
    for label, b in boundaries.items():
        st = styles[label]
        has_center = centers is not None and label in centers
        ax.plot(b[:, 0], b[:, 1], color=st.color, ls=st.linestyle, lw=1.4, label="_" if has_center else
                label + (" (off frame)" if label in too_wide else ""))
        if has_center:  # the centre shows the marker; the legend entry both
            c = np.asarray(centers[label], dtype=float)
            ax.plot(*c, st.marker, color=st.color, ms=4.5, mec="white", mew=0.4)
            ax.plot([], [], color=st.color, ls=st.linestyle, lw=1.4, marker=st.marker, ms=4.5, mec="white",
                    mew=0.4, label=label + (" (off frame)" if label in too_wide else ""))
    if truth_2d is not None:
        tr = np.asarray(truth_2d, dtype=float)
        if tr.shape != (2,):
            raise InputError(f"truth_2d must be (2,), got shape {tr.shape}.")
        ax.plot(*tr, styles["truth"].marker, color=styles["truth"].color, ms=10, label="truth")
    framed = [b for label, b in boundaries.items() if not _frame_exempt(label) and label not in too_wide]
    framed += reference
    framed += [np.asarray(truth_2d, dtype=float)[None, :]] if truth_2d is not None else []
    if framed:  # limits from the exact set and the estimates; John's ellipsoid (p x the inner) may run past
        pts = np.vstack(framed)
        lo2, hi2 = pts.min(axis=0), pts.max(axis=0)
        pad = 0.06 * np.where(hi2 > lo2, hi2 - lo2, np.maximum(np.abs(hi2), 1.0))
        ax.set_xlim(lo2[0] - pad[0], hi2[0] + pad[0])
        ax.set_ylim(lo2[1] - pad[1], hi2[1] + pad[1])
        span = hi2 - lo2
        same_units = units is not None and units[0] == units[1]
        if same_units and span.min() > 0 and span.max() / span.min() <= 4.0:
            ax.set_aspect("equal", adjustable="box")  # the limits stay; the axes box takes the shape
    else:
        ax.autoscale_view()
    ax.set_xlabel(_label(names[0], units[0] if units is not None else None))
    ax.set_ylabel(_label(names[1], units[1] if units is not None else None))
    ax.grid(alpha=0.3)
    _figure_legend(fig, *ax.get_legend_handles_labels(), where="right")
    return fig


def _frame_exempt(label: str) -> bool:
    """Sets that do not set a projection's limits: John's outer ellipsoid, always the widest."""
    return "john" in label.lower()


def width_ratios(widths, reference: str = "LP exact") -> Figure:
    """Per-parameter interval width of each set estimate over the exact LP width: a dot plot, one
    row per parameter, one dot per estimate on a log axis (the reference is the line at 1).

    widths : DataFrame, one row per parameter (index = names), one column per estimate, holding
        interval widths hi - lo; column ``reference`` holds the exact LP widths. Ratios > 1 are
        outer bounds (looser than exact), < 1 inner ones.
    """
    if reference not in widths.columns:
        raise InputError(f"widths has no reference column {reference!r}; columns are {list(widths.columns)}.")
    ref = widths[reference].to_numpy(dtype=float)
    if np.any(~(ref > 0)):
        raise InputError(f"the reference widths ({reference}) must be > 0 to divide by.")
    others = [c for c in widths.columns if c != reference]
    if not others:
        raise InputError("width_ratios needs at least one estimate column besides the reference.")
    p = len(widths.index)
    fig = _figure(8.5, 0.32 * p + 1.3)
    ax = fig.subplots()
    styles = series_styles(others)
    y = np.arange(p)
    offset = np.linspace(-0.25, 0.25, len(others)) if len(others) > 1 else np.zeros(1)
    ratios = []
    for k, label in enumerate(others):
        ratio = widths[label].to_numpy(dtype=float) / ref
        ratios.append(ratio)
        ax.plot(ratio, y + offset[k], ls="none", marker=styles[label].marker, ms=6, color=styles[label].color,
                markeredgecolor="white", markeredgewidth=0.5, label=label)
    ref = style_for(reference) if _named_style(reference) is not None else REFERENCE_STYLES["LP exact"]
    ax.axvline(1.0, color=ref.color, lw=1.0, ls=ref.linestyle, label=f"{reference} (= 1)")
    ax.set_xscale("log")
    finite = np.concatenate(ratios)
    finite = finite[np.isfinite(finite) & (finite > 0)]
    lo, hi = (min(0.8, finite.min() / 1.3), max(1.25, finite.max() * 1.3)) if finite.size else (0.5, 2.0)
    ax.set_xlim(lo, hi)
    decades = np.log10(hi / lo)  # label 1-2-5 within a few decades (else only the 1 of each is labelled)
    ax.xaxis.set_major_locator(LogLocator(10.0, subs=(1.0, 2.0, 5.0) if decades <= 3 else (1.0,)))
    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_yticks(y, [str(i) for i in widths.index])
    ax.invert_yaxis()
    ax.tick_params(labelsize=9)
    ax.set_xlabel(f"width / {reference} width (log scale)", fontsize=10)
    ax.grid(axis="x", which="both", alpha=0.3)
    ax.grid(axis="y", alpha=0.15)
    _figure_legend(fig, *ax.get_legend_handles_labels())
    return fig


def log_volume_bars(log_volumes_per_dim: Mapping[str, float]) -> Figure:
    """Horizontal bars of ln vol / p per estimate (the size of each set, comparable across p).

    log_volumes_per_dim : {label: ln(volume) / p}; NaN entries (point estimates) are left out.
    """
    items = [(k, float(v)) for k, v in log_volumes_per_dim.items() if np.isfinite(v)]
    if not items:
        raise InputError("log_volume_bars needs at least one finite log-volume.")
    labels, values = zip(*items, strict=True)
    fig = _figure(5.5, 0.45 * len(items) + 1.0)
    ax = fig.subplots()
    y = np.arange(len(items))
    styles = series_styles(labels)
    bars = ax.barh(y, values, color=[styles[k].color for k in labels])
    ax.bar_label(bars, labels=[f"{v:.3g}" for v in values], fontsize=9, padding=2)
    ax.set_yticks(y, labels)
    ax.invert_yaxis()
    ax.axvline(0.0, color="#333333", lw=0.8)
    ax.set_xlabel("ln(volume) / p  (smaller is tighter)")
    ax.margins(x=0.15)
    ax.grid(axis="x", alpha=0.3)
    return fig


def volume_history(histories: Mapping[str, object], t=None, *, max_points: int = 4000) -> Figure:
    """ln volume of the set against sample (or time), one line per recursive set estimator.

    histories : {label: (index (K,), log_volumes (K,))} or {label: History};
        traces that are all NaN (point estimators) are skipped.
    t : (N,) [s] or None, as in :func:`parameter_convergence`.
    max_points : longer traces are drawn with every k-th recorded point only.
    """
    fig = _figure(6.5, 3.0)
    ax = fig.subplots()
    traces = {}
    for label, h in histories.items():
        index, logv = _trace(h, "log_volumes")
        if logv.shape != index.shape:
            raise InputError(f"history {label!r}: index {index.shape} and log_volumes {logv.shape} differ.")
        if not np.all(np.isnan(logv)):
            traces[label] = (index, logv)
    styles = series_styles(list(traces))
    for k, (label, (index, logv)) in enumerate(traces.items()):
        s = _stride(index.shape[0], max_points)
        x = _x_axis(t, index)[s]
        ax.plot(x, logv[s], label=label, **_line_kw(styles[label], x.shape[0], k, len(traces), lw=1.3))
    drawn = len(traces)
    if drawn == 0:
        raise InputError("volume_history needs at least one history with finite log-volumes.")
    ax.set_xlabel("time [s]" if t is not None else "sample")
    ax.set_ylabel("ln(volume)")
    ax.grid(alpha=0.3)
    _figure_legend(fig, *ax.get_legend_handles_labels())
    return fig


def bound_sweep(rows: list[dict]) -> Figure:
    """What the bound changes (:func:`boundid.studies.bounds.bound_sweep` rows): the exact intervals'
    widths over the prior box's, and the rows each reference point violates, against the factor over
    the smallest consistent bounds (log axis)."""
    if not rows:
        raise InputError("bound_sweep needs at least one row.")
    f = np.array([r["factor"] for r in rows])
    fig = _figure(9.0, 3.4)
    left, right = fig.subplots(1, 2)
    for key, ls, marker, color in (("mean width / prior", "-", "o", PALETTE["LP exact"]),
                                   ("median width / prior", "--", "s", "#777777")):
        left.semilogx(f, [r[key] for r in rows], ls=ls, marker=marker, color=color, label=key)
    left.set_ylabel("exact interval width / prior box width")
    left.set_ylim(bottom=0.0)
    refs = {k.removeprefix("rows ").removesuffix(" violates"): k for k in rows[0] if k.startswith("rows ")}
    styles = series_styles(list(refs))
    for label, key in refs.items():
        st = styles[label]
        right.semilogx(f, [r[key] for r in rows], marker=st.marker, ls=st.linestyle, color=st.color, label=label)
    right.set_ylabel("rows outside their bound")
    right.set_ylim(bottom=0.0)
    renderer = fig.canvas.get_renderer()
    for ax, title in ((left, None), (right, "point")):  # above each axes, in as many columns as it holds
        handles, labels = ax.get_legend_handles_labels()
        if labels:
            _fit_ncols(lambda c, ax=ax, h=handles, lab=labels, ti=title: ax.legend(
                h, lab, loc="lower center", bbox_to_anchor=(0.5, 1.02), ncols=c, fontsize=LEGEND_PT, frameon=False,
                title=ti, title_fontsize=LEGEND_PT), len(labels), ax.bbox.width, renderer)
    for ax in (left, right):
        ax.set_xlabel("e_max / smallest consistent bound")
        ax.set_xticks(f, [f"{v:g}" for v in f], minor=False)
        ax.minorticks_off()
        ax.grid(alpha=0.3)
    return fig
