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


# ------------------------------------------------------------------ series drawn alike, the re-simulation
def _resimulation_data():
    """Two joints, 400 samples; three RLS re-simulations and one WLS, each off the measurement by its own amount."""
    t = np.linspace(0.0, 10.0, 400)
    q = np.column_stack([np.sin(t), 0.5 * np.cos(2.0 * t)])
    sims = {f"RLS / {rn}": q + 0.02 * (k + 1) * np.sin(t + k)[:, None]
            for k, rn in enumerate(("filtered_dynamic", "supplied_energy", "filtered_power"))}
    sims["WLS / inverse_dynamic"] = 1.05 * q
    return t, q, sims


def _old_resimulation_figure(t, q, sims):
    """The re-simulation figure as it was: every RLS model in the RLS colour (#CC79A7), the legend in
    5 columns centred above the axes of an 8-inch figure, wider than the figure."""
    fig = Figure(figsize=(8.0, 4.5), dpi=110, layout="constrained")
    axes = fig.subplots(2, 2, sharex=True, squeeze=False)
    colour = {"RLS": "#CC79A7", "WLS": "#D55E00"}
    for i in range(2):
        ax, ax_err = axes[i]
        ax.plot(t, q[:, i], color="#4D4D4D", lw=1.6, label="measured")
        for label, qs in sims.items():
            ax.plot(t, qs[:, i], color=colour[label.split(" / ")[0]], lw=1.0, ls="--", label=label)
            ax_err.plot(t, qs[:, i] - q[:, i], color=colour[label.split(" / ")[0]], lw=1.0, label=label)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside upper center", ncols=5, frameon=False, fontsize=11)
    return fig


def test_the_old_resimulation_figure_fails_and_the_new_one_passes():
    """Reference: the old figure's defects, known by construction: a 5-column legend of 11-pt labels
    wider than 8 inches (cut on both sides), and the three RLS lines of each axes in one colour,
    marker and line style. trajectory_comparison on the same data: no problem at all, with its
    legend at >= 9 pt on a 1000-px page, and the series of each axes pairwise distinct."""
    from boundid.report.figure_check import PAGE_WIDTH_PX
    from boundid.report.figures import trajectory_comparison

    t, q, sims = _resimulation_data()
    old = _old_resimulation_figure(t, q, sims)
    problems = figure_problems(old)
    clipped = [p for p in problems if p.startswith("figure legend reaches outside the figure")]
    assert len(clipped) == 1 and "left by" in clipped[0] and "right by" in clipped[0]
    twins = [p for p in problems if p.startswith("series ")]
    # per axes: 3 RLS lines alike -> pairs (1,2), (1,3), (2,3) against the first seen: 2 reports; 4 axes
    assert len(twins) == 2 * 4
    assert all("share colour #cc79a7" in p and "cannot tell them apart" in p for p in twins)
    assert any("'RLS / filtered_dynamic' and 'RLS / supplied_energy' of axes 1" in p for p in twins)
    with pytest.raises(AssertionError, match=r"(?s)figure 'resimulation' cuts off.*figure legend reaches outside"):
        assert_nothing_clipped(old, "resimulation")
    # the figure legend at 11 pt on an 880-px image is fine; at 7 pt it would show at 8 pt: reported
    old.legends[0].remove()
    old.legend(loc="outside right upper", fontsize=7)
    assert any("shows its text at 8.0 pt" in p for p in figure_problems(old, display_width_px=PAGE_WIDTH_PX))

    new = trajectory_comparison(t, q, sims)
    assert figure_problems(new, display_width_px=PAGE_WIDTH_PX) == []
    for ax in new.axes:
        keys = [(ln.get_color(), ln.get_marker(), ln.get_linestyle()) for ln in ax.lines
                if not ln.get_label().startswith("_")]
        assert len(keys) == len(set(keys)) >= 4
    assert {t.get_text() for t in new.legends[0].get_texts()} == {"measured", *sims}


def test_bbox_inches_tight_decides_what_is_clipped():
    """Reference: savefig(bbox_inches="tight") keeps the tight box of the artists in the layout: a
    legend past the figure edge is then saved (the PNG grows, the frame's last pixel column is
    inside the image); one left out of the layout is cut, and reported."""
    fig, ax = _line_figure(figsize=(4.0, 3.0), dpi=100)
    leg = ax.legend(loc="upper left", bbox_to_anchor=(0.9, 1.0), frameon=True, edgecolor="#ff0000")
    assert any("reaches outside the figure" in p for p in figure_problems(fig))
    assert figure_problems(fig, bbox_inches="tight") == []
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    img = np.asarray(Image.open(buf).convert("RGB")).astype(int)
    red = (img[:, :, 0] > 200) & (img[:, :, 1] < 120) & (img[:, :, 2] < 120)
    assert img.shape[1] > 400 and red.any() and not red[:, -1].any()
    leg.set_in_layout(False)
    assert any(p.startswith("legend of axes 1 ('title') reaches outside the saved image (right by")
               for p in figure_problems(fig, bbox_inches="tight"))
    with pytest.raises(InputError, match="bbox_inches"):
        figure_problems(fig, bbox_inches="loose")


def test_fills_drawn_alike_are_reported():
    """Two labelled fills of one face and edge colour are reported; a hatch tells them apart."""
    fig = Figure(figsize=(4.0, 3.0), layout="constrained")
    ax = fig.subplots()
    x = np.linspace(0.0, 1.0, 5)
    ax.fill_between(x, 0.0, 1.0, color="#0072B2", alpha=0.3, label="band a")
    band_b = ax.fill_between(x, 1.0, 2.0, color="#0072B2", alpha=0.3, label="band b")
    assert [p for p in figure_problems(fig) if "'band a' and 'band b'" in p]
    band_b.set_hatch("//")
    assert figure_problems(fig) == []


def test_sixteen_series_have_sixteen_styles():
    """Reference: the palette's rule (colour k mod 8, line style (k // 8) mod 4, marker (k + k // 8)
    mod 8): the 16 (colour, marker, line style) triples differ; so do the triples of 16 lines
    volume_history draws, and the figure check finds nothing in it; two series that share a
    colour differ in both marker and line style."""
    from boundid.report.figures import SERIES, series_style, volume_history

    triples = [(s.color, s.marker, s.linestyle) for s in SERIES]
    assert len(SERIES) == 16 and len(set(triples)) == 16
    for a, b in ((a, b) for i, a in enumerate(SERIES) for b in SERIES[i + 1:]):
        assert a.color != b.color or (a.marker != b.marker and a.linestyle != b.linestyle)
    assert len({series_style(k) for k in range(64)}) == 64
    histories = {f"estimator {k}": (np.arange(50) * 4, np.linspace(0.0, -k - 1.0, 50)) for k in range(16)}
    fig = volume_history(histories)
    drawn = [(ln.get_color(), ln.get_marker(), ln.get_linestyle()) for ln in fig.axes[0].lines]
    assert len(drawn) == 16 and len(set(drawn)) == 16
    assert figure_problems(fig, display_width_px=1000) == []


def test_a_study_gives_every_series_its_own_style():
    """Reference: StudyConfig.styles on the direct-drive study: RLS on three regression models and
    every other estimator get distinct palette entries, in the order of the file; an estimator's own
    label takes its style on the exact regression."""
    from pathlib import Path

    from boundid.report.figures import method_styles, series_styles, study_styles
    from boundid.studies.config import load_study

    cfg = load_study(Path(__file__).parents[1] / "studies" / "direct_drive_rls.toml")
    styles = study_styles(cfg)
    series = [f"{e.label} / {rn}" for e in cfg.estimators for rn in e.regressions]
    assert len({styles[s] for s in series}) == len(series) == 13
    assert styles["WLS"] == styles["WLS / filtered_dynamic"] != styles["WLS / inverse_dynamic"]
    with method_styles(styles):
        picked = series_styles([*series[:3], "filtered_dynamic", "truth"])
    assert picked["RLS / supplied_energy"] == styles["RLS / supplied_energy"]
    assert len(set(picked.values())) == 5
