"""The figure check: artists cut off by the figure edge, and overlapping tick labels.

Reference: figures built here whose geometry is known by construction (a legend anchored at 90 %
of the axes width, wider than the remaining 10 %; a figure title longer than the figure; 21 tick
labels of 6 characters on a 3-inch axis), and the same contents laid out by matplotlib's
constrained layout with the legend outside the axes, which must pass. The clipped legend is also
confirmed on the rendered PNG: the legend's frame reaches the image's last pixel column.
"""

import io

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

from boundid.errors import InputError
from boundid.report.figure_check import assert_nothing_clipped, drawn_tick_labels, figure_problems


def _line_figure(**fig_kw):
    fig = Figure(**fig_kw)
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0], label="a legend entry long enough to leave the figure")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="title")
    return fig, ax


def test_a_legend_anchored_past_the_edge_is_reported_and_seen_in_the_png():
    """The legend's left edge is at 90 % of the axes: its frame runs past the right edge of the
    figure, which the PNG shows as legend-frame pixels in the last column."""
    fig, ax = _line_figure(figsize=(4.0, 3.0), dpi=100)
    ax.legend(loc="upper left", bbox_to_anchor=(0.9, 1.0), frameon=True, edgecolor="#ff0000")
    problems = figure_problems(fig)
    assert any(p.startswith("legend of axes 1 ('title') reaches outside the figure (right by") for p in problems)
    with pytest.raises(AssertionError, match="legend of axes 1"):
        assert_nothing_clipped(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    img = np.asarray(Image.open(buf).convert("RGB")).astype(int)
    red = (img[:, :, 0] > 200) & (img[:, :, 1] < 120) & (img[:, :, 2] < 120)
    assert red[:, -1].any(), "the legend frame is cut by the right edge of the PNG"


def test_the_same_contents_laid_out_outside_the_axes_pass():
    """fig.legend(loc='outside right upper') with a constrained layout: nothing reported."""
    fig, ax = _line_figure(figsize=(6.0, 3.0), layout="constrained")
    fig.legend(loc="outside right upper")
    fig.suptitle("a figure title")
    assert figure_problems(fig) == []
    assert_nothing_clipped(fig)


def test_a_title_longer_than_the_figure_is_reported():
    fig, _ = _line_figure(figsize=(3.0, 2.0))
    fig.suptitle("a figure title far too long for a figure only three inches wide, cut at both ends")
    assert any("figure text 'a figure title far too long" in p and "left by" in p and "right by" in p
               for p in figure_problems(fig))


def test_crowded_tick_labels_are_reported_and_thinned_ones_pass():
    """21 labels such as '0.2525' on a 3-inch axis overlap; 4 of them do not."""
    fig = Figure(figsize=(3.0, 2.5), layout="constrained")
    ax = fig.subplots()
    ax.plot([0.2525, 0.2725], [0.0, 1.0])
    ax.set_xticks(np.linspace(0.2525, 0.2725, 21))
    ax.xaxis.set_major_formatter("{x:.4f}")
    problems = figure_problems(fig)
    assert problems and all(p.startswith("x tick labels") for p in problems)
    ax.set_xticks(np.linspace(0.2525, 0.2725, 4))
    assert figure_problems(fig) == []


def test_tick_labels_outside_the_view_are_not_counted():
    """matplotlib keeps labels for tick locations beyond the view limits without drawing them;
    only the drawn ones are checked."""
    fig = Figure(figsize=(4.0, 3.0), layout="constrained")
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_xticks([-50.0, 0.0, 0.5, 1.0, 50.0])
    ax.set_xlim(0.0, 1.0)
    assert figure_problems(fig) == []  # draws the figure, which sets the labels' texts
    assert [t.get_text() for t in drawn_tick_labels(ax.xaxis)] == ["0.0", "0.5", "1.0"]


def test_bad_input():
    with pytest.raises(InputError, match="matplotlib Figure"):
        figure_problems("not a figure")
