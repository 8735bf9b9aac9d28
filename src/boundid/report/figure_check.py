"""Is anything in a matplotlib figure cut off or written over? A check on the drawn figure.

:func:`figure_problems` draws the figure (Agg) and looks at the window extent, in pixels, of every
artist a reader has to read: each Axes box, its titles and texts, the tick labels actually drawn
(those inside the view limits), the axis labels and offset texts, every legend (of an Axes or of
the figure) and the figure's own texts (suptitle, supxlabel ...). It reports each one that reaches
outside the figure (it would be cut off in the PNG: a clipped legend was a real defect of the study pages) and each
pair of tick labels of one axis that overlap or touch ("0.25250.2550"). Texts clipped to their Axes
(``clip_on=True``) are skipped: only their part inside the Axes is drawn.

:func:`assert_nothing_clipped` is the pytest form (AssertionError listing the problems), for any
figure a test builds; :class:`boundid.teaching.Handout` runs :func:`figure_problems` on every
figure and animation frame a lesson adds.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure, SubFigure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from boundid.errors import InputError

TOLERANCE_PX = 1.0  # antialiasing may touch the last pixel row; anything more is cut off
MIN_GAP_PX = 2.0  # two tick labels closer than this read as one ("0.25250.2550")


def _renderer(fig: Figure):
    """Draw ``fig`` with Agg (attaching an Agg canvas to a bare ``Figure()``) and return the renderer."""
    canvas = fig.canvas
    if not hasattr(canvas, "get_renderer"):
        canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _quoted(text: str) -> str:
    s = " ".join(text.split())
    return repr(s if len(s) <= 40 else s[:37] + "...")


def _text_label(t: Text) -> str:
    return _quoted(t.get_text())


def _shown(t: Text) -> bool:
    return t.get_visible() and bool(t.get_text().strip())


def _axes_name(ax: Axes, k: int) -> str:
    title = next((ax.get_title(loc) for loc in ("center", "left", "right") if ax.get_title(loc)), "")
    return f"axes {k + 1}" + (f" ({_quoted(title)})" if title else "")


def drawn_tick_labels(axis: Axis) -> list[Text]:
    """The tick labels of ``axis`` that the last draw put on the figure: visible, non-empty, and
    at a tick location inside the axis' view interval (matplotlib keeps labels for locations
    outside it, not drawn, at stale positions)."""
    lo, hi = sorted(axis.get_view_interval())
    span = hi - lo
    out = []
    for ticks in (axis.get_major_ticks(), axis.get_minor_ticks()):
        for tick in ticks:
            loc = tick.get_loc()
            if loc is None or not lo - 1e-9 * span <= loc <= hi + 1e-9 * span:
                continue
            out += [lab for lab in (tick.label1, tick.label2) if _shown(lab)]
    return out


def _artists(fig: Figure | SubFigure, renderer, where: str = "") -> Iterator[tuple[str, Bbox]]:
    """(description, window extent) of every artist a reader reads in ``fig`` (and its subfigures)."""
    for k, ax in enumerate(fig.axes if isinstance(fig, Figure) else fig.get_axes()):
        if not ax.get_visible():
            continue
        name = where + _axes_name(ax, k)
        yield name, ax.get_window_extent(renderer)
        for child in ax.get_children():
            if isinstance(child, Text) and _shown(child) and not child.get_clip_on():
                yield f"text {_text_label(child)} of {name}", child.get_window_extent(renderer)
        for letter, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            if not axis.get_visible():
                continue
            for lab in drawn_tick_labels(axis):
                yield f"{letter} tick label {_text_label(lab)} of {name}", lab.get_window_extent(renderer)
            for t, what in ((axis.label, "label"), (axis.get_offset_text(), "offset text")):
                if _shown(t):
                    yield f"{letter} axis {what} {_text_label(t)} of {name}", t.get_window_extent(renderer)
        legend = ax.get_legend()
        if legend is not None and legend.get_visible():
            yield f"legend of {name}", legend.get_window_extent(renderer)
    for legend in fig.legends:
        if legend.get_visible():
            yield f"{where}figure legend", legend.get_window_extent(renderer)
    for t in fig.texts:
        if _shown(t):
            yield f"{where}figure text {_text_label(t)}", t.get_window_extent(renderer)
    for j, sub in enumerate(fig.subfigs):
        yield from _artists(sub, renderer, f"{where}subfigure {j + 1}, ")


def _overlaps(fig: Figure, renderer) -> list[str]:
    """Pairs of drawn tick labels of one axis closer than MIN_GAP_PX (or overlapping)."""
    out = []
    for k, ax in enumerate(fig.get_axes()):
        if not ax.get_visible():
            continue
        for letter, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            boxes = [(lab, lab.get_window_extent(renderer)) for lab in drawn_tick_labels(axis)]
            for i, (a, ba) in enumerate(boxes):
                for b, bb in boxes[i + 1:]:
                    dx = min(ba.x1, bb.x1) - max(ba.x0, bb.x0)
                    dy = min(ba.y1, bb.y1) - max(ba.y0, bb.y0)
                    if dx > -MIN_GAP_PX and dy > -MIN_GAP_PX:
                        gap = -min(dx, dy)
                        out.append(f"{letter} tick labels {_text_label(a)} and {_text_label(b)} of {_axes_name(ax, k)} "
                                   + (f"overlap by {-gap:.0f} px" if gap < 0 else f"are only {gap:.0f} px apart"))
    return out


def figure_problems(fig: Figure) -> list[str]:
    """Everything a reader cannot read in ``fig``: artists reaching outside the figure and
    overlapping tick labels, one sentence each (empty list: the figure is clean).

    Draws the figure (Agg) at its own dpi; extents are in pixels of that drawing.
    """
    if not isinstance(fig, Figure):
        raise InputError(f"figure_problems needs a matplotlib Figure, got {type(fig).__name__}.")
    renderer = _renderer(fig)
    W, H = fig.bbox.width, fig.bbox.height
    problems = []
    for what, box in _artists(fig, renderer):
        if not np.all(np.isfinite(box.extents)) or box.width == 0 and box.height == 0:
            continue
        out = (-box.x0, -box.y0, box.x1 - W, box.y1 - H)  # left, bottom, right, top
        if max(out) > TOLERANCE_PX:
            sides = ", ".join(f"{side} by {d:.0f} px" for side, d in zip(("left", "bottom", "right", "top"), out,
                                                                          strict=True) if d > TOLERANCE_PX)
            problems.append(f"{what} reaches outside the figure ({sides})")
    return problems + _overlaps(fig, renderer)


def assert_nothing_clipped(fig: Figure) -> None:
    """pytest helper: AssertionError listing every artist of ``fig`` that is cut off by the figure
    edge, and every pair of overlapping tick labels (see :func:`figure_problems`)."""
    problems = figure_problems(fig)
    assert not problems, "the figure cuts off or overlaps what a reader must read:\n- " + "\n- ".join(problems)
