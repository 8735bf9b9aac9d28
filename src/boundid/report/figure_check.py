"""Is anything in a matplotlib figure cut off, written over or indistinguishable? A check on the drawn figure.

:func:`figure_problems` draws the figure (Agg) and looks at the window extent, in pixels, of every
artist a reader has to read: each Axes box, its titles and texts, the tick labels actually drawn
(those inside the view limits), the axis labels and offset texts, every legend (of an Axes or of
the figure) and the figure's own texts (suptitle, supxlabel ...). It reports

* each one that reaches outside the region the image keeps (it would be cut off in the PNG: a
  legend wider than the figure, clipped on both sides, was a real defect of the study pages). The
  region is the figure's box, as ``savefig`` keeps it by default (and :class:`boundid.report.Page`
  saves); with ``bbox_inches="tight"`` savefig keeps the tight box of the artists that take part in
  the layout instead (padded by ``savefig.pad_inches``): what reaches past the figure is then saved
  (the image grows), and only an artist left out of the layout (``set_in_layout(False)``) can be
  cut, so pass the same ``bbox_inches`` the figure is saved with;
* each pair of tick labels of one axis that overlap or touch ("0.25250.2550");
* each pair of labelled series of one axes that a reader cannot tell apart: lines with the same
  colour, marker and line style (three re-simulations in one colour were another real defect),
  or patches and collections (fills, polygons) with the same face, edge, line style and hatch;
* with ``display_width_px`` (the width the page shows images at, :data:`PAGE_WIDTH_PX`), each
  legend whose text would show smaller than :data:`MIN_LEGEND_PT` points there.

Texts clipped to their Axes (``clip_on=True``) are skipped: only their part inside the Axes is
drawn. Series whose label starts with "_" (not in a legend) are not compared.

:func:`assert_nothing_clipped` is the pytest form (AssertionError naming the figure and listing the
problems), for any figure a test builds; :class:`boundid.teaching.Handout` runs
:func:`figure_problems` on every figure and animation frame a lesson adds.
"""

from __future__ import annotations

from collections.abc import Iterator

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import Collection
from matplotlib.colors import to_hex
from matplotlib.figure import Figure, SubFigure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from boundid.errors import InputError

TOLERANCE_PX = 1.0  # antialiasing may touch the last pixel row; anything more is cut off
MIN_GAP_PX = 2.0  # two tick labels closer than this read as one ("0.25250.2550")
PAGE_WIDTH_PX = 1000  # a report page's column (main: 1040 px less 2 x 1.25 rem padding); wider images shrink
MIN_LEGEND_PT = 9.0  # legend text smaller than this on the page is hard to read
CSS_PX_PER_IN = 96.0  # a browser's CSS pixel: 1/96 in, 1 pt = 1/72 in


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


def _none(value) -> str:
    return "none" if value is None or str(value) in ("None", "none", "", " ") else str(value)


def _hex(color) -> str:
    rgba = np.asarray(color, dtype=float) if not isinstance(color, str) else color
    if not isinstance(rgba, str) and rgba.ndim == 2:  # a collection: its first colour (one per series)
        if rgba.shape[0] == 0:
            return "none"
        rgba = rgba[0]
    if not isinstance(rgba, str) and rgba.shape[-1] == 4 and rgba[3] == 0:
        return "none"
    return to_hex(rgba, keep_alpha=False)


def series_key(artist) -> tuple[str, ...] | None:
    """What tells a labelled series apart on the page: ("line", colour, marker, line style) of a
    Line2D; ("fill", face colour, edge colour, line style, hatch) of a patch or collection; None
    for other artists and for lines drawing nothing (no marker and no line)."""
    if isinstance(artist, Line2D):
        marker, ls = _none(artist.get_marker()), _none(artist.get_linestyle())
        if marker == "none" and ls == "none":
            return None
        return "line", _hex(artist.get_color()), marker, ls
    if isinstance(artist, Patch | Collection):
        ls = artist.get_linestyle()
        ls = _none(ls[0] if isinstance(ls, list) and ls else ls)
        return "fill", _hex(artist.get_facecolor()), _hex(artist.get_edgecolor()), ls, _none(artist.get_hatch())
    return None


def _describe_key(key: tuple[str, ...]) -> str:
    if key[0] == "line":
        return f"colour {key[1]}, marker {key[2]!r} and line style {key[3]!r}"
    return f"face {key[1]}, edge {key[2]}, line style {key[3]!r} and hatch {key[4]!r}"


def _twins(fig: Figure | SubFigure, where: str = "") -> list[str]:
    """Pairs of labelled series of one axes with the same :func:`series_key`."""
    out = []
    for k, ax in enumerate(fig.axes if isinstance(fig, Figure) else fig.get_axes()):
        if not ax.get_visible():
            continue
        seen: dict[tuple, str] = {}
        for artist in ax.get_children():
            label = str(artist.get_label() or "")
            if not artist.get_visible() or not label or label.startswith("_"):
                continue
            key = series_key(artist)
            if key is None:
                continue
            if key in seen and seen[key] != label:
                out.append(f"series {_quoted(seen[key])} and {_quoted(label)} of {where}{_axes_name(ax, k)} "
                           f"share {_describe_key(key)}: a reader cannot tell them apart")
            seen.setdefault(key, label)
    for j, sub in enumerate(fig.subfigs):
        out += _twins(sub, f"{where}subfigure {j + 1}, ")
    return out


def _saved_box(fig: Figure, renderer, bbox_inches) -> Bbox:
    """The region of ``fig`` (pixels of the drawing) that ``savefig(bbox_inches=...)`` keeps."""
    if bbox_inches is None:
        return fig.bbox
    if bbox_inches == "tight":
        pad = mpl.rcParams["savefig.pad_inches"]
        pad = 0.0 if pad == "layout" else float(pad)
        return Bbox(fig.get_tightbbox(renderer).padded(pad).get_points() * fig.dpi)
    if isinstance(bbox_inches, Bbox):
        return Bbox(bbox_inches.get_points() * fig.dpi)
    raise InputError(f"bbox_inches must be None, 'tight' or a Bbox in inches (as savefig takes), got {bbox_inches!r}.")


def _small_legends(fig: Figure | SubFigure, scale: float, where: str = "") -> list[str]:
    """Legends whose texts show below MIN_LEGEND_PT points when one figure point shows ``scale`` points."""
    out = []
    legends = [(f"legend of {where}{_axes_name(ax, k)}", ax.get_legend())
               for k, ax in enumerate(fig.axes if isinstance(fig, Figure) else fig.get_axes())]
    legends += [(f"{where}figure legend", leg) for leg in fig.legends]
    for what, leg in legends:
        if leg is None or not leg.get_visible():
            continue
        sizes = [t.get_fontsize() for t in leg.get_texts() if _shown(t)]
        if sizes and min(sizes) * scale < MIN_LEGEND_PT - 1e-9:
            out.append(f"{what} shows its text at {min(sizes) * scale:.1f} pt on the page (font size "
                       f"{min(sizes):g} pt), below {MIN_LEGEND_PT:g} pt")
    for j, sub in enumerate(fig.subfigs):
        out += _small_legends(sub, scale, f"{where}subfigure {j + 1}, ")
    return out


def figure_problems(fig: Figure, *, bbox_inches=None, dpi: float | None = None,
                    display_width_px: float | None = None) -> list[str]:
    """Everything a reader cannot read in ``fig``: artists reaching outside the saved image,
    overlapping tick labels and labelled series of one axes drawn alike, one sentence each (empty
    list: the figure is clean). Check the figure as it will be saved, before saving it.

    bbox_inches : None (the whole figure, savefig's default) or "tight" (or a Bbox in inches):
        what ``savefig`` is given, which decides the region the image keeps.
    dpi : the dpi the image is saved at (default: the figure's), for the legend size on the page.
    display_width_px : the page's width for images (:data:`PAGE_WIDTH_PX`), images wider are shown
        smaller; given, legends whose text shows below :data:`MIN_LEGEND_PT` there are reported too.

    Draws the figure (Agg) at its own dpi; extents are in pixels of that drawing.
    """
    if not isinstance(fig, Figure):
        raise InputError(f"figure_problems needs a matplotlib Figure, got {type(fig).__name__}.")
    renderer = _renderer(fig)
    saved = _saved_box(fig, renderer, bbox_inches)
    edge = "figure" if bbox_inches is None else "saved image"
    problems = []
    for what, box in _artists(fig, renderer):
        if not np.all(np.isfinite(box.extents)) or box.width == 0 and box.height == 0:
            continue
        out = (saved.x0 - box.x0, saved.y0 - box.y0, box.x1 - saved.x1, box.y1 - saved.y1)  # left, bottom, right, top
        if max(out) > TOLERANCE_PX:
            sides = ", ".join(f"{side} by {d:.0f} px" for side, d in zip(("left", "bottom", "right", "top"), out,
                                                                          strict=True) if d > TOLERANCE_PX)
            problems.append(f"{what} reaches outside the {edge} ({sides})")
    problems += _overlaps(fig, renderer) + _twins(fig)
    if display_width_px is not None:
        save_dpi = fig.dpi if dpi is None else float(dpi)
        image_px = saved.width / fig.dpi * save_dpi
        scale = save_dpi / CSS_PX_PER_IN * min(1.0, display_width_px / image_px)  # page points per figure point
        problems += _small_legends(fig, scale)
    return problems


def assert_nothing_clipped(fig: Figure, name: str | None = None, **kw) -> None:
    """pytest helper: AssertionError naming the figure (``name``, else its ``get_label()``) and
    listing every artist of ``fig`` that is cut off by the edge of the saved image, every pair of
    overlapping tick labels and of series drawn alike (see :func:`figure_problems`, which takes
    ``kw``)."""
    problems = figure_problems(fig, **kw)
    what = repr(name or fig.get_label()) if (name or fig.get_label()) else "the figure"
    assert not problems, (f"figure {what} cuts off, overlaps or draws alike what a reader must read:\n- "
                          + "\n- ".join(problems))
