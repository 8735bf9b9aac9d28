"""Tests of the report layer: figures, tables, self-contained HTML pages, the browser check."""

from __future__ import annotations

import base64
import dataclasses
import io
import itertools
import re
import typing
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure
from PIL import Image

from boundid.errors import InputError
from boundid.estimators import Estimate, History
from boundid.estimators.registry import METHODS
from boundid.report import (
    PALETTE,
    Page,
    browser,
    color_for,
    deviation_percent,
    estimate_summary,
    format_frame,
    latex_table,
    log_volume_bars,
    markdown_table,
    method_styles,
    parameter_convergence,
    parameter_table,
    projection_2d,
    style_for,
    torque_bounds,
    trajectory_comparison,
    volume_history,
    width_ratios,
    widths,
    write_index,
)
from boundid.sets import Box, Ellipsoid, VertexPolytope

NAMES = ["m_1", "I^2", "fv"]
TRUTH = np.array([2.0, 0.5, -0.1])


def _history(K=30, p=3, seed=0):
    rng = np.random.default_rng(seed)
    index = np.arange(K) * 2
    centers = TRUTH[:p] + rng.standard_normal((K, p)) / (1 + index[:, None])
    return History(index, centers, np.linspace(3.0, -4.0, K))


def _estimate(label, radius=0.3, kind="guaranteed"):
    c = TRUTH + 0.05
    e = Ellipsoid.ball(c, radius)
    return Estimate(label, c, e, e.intervals(), kind, level=0.95 if kind == "statistical" else None,
                    names=tuple(NAMES), history=_history(), time_s=0.01)


# ------------------------------------------------------------------------------------ styles
def _variants():
    """Every registered method with every combination of its Literal options."""
    for m in METHODS.values():
        hints = typing.get_type_hints(m.options)
        choices = {f.name: typing.get_args(hints[f.name]) for f in dataclasses.fields(m.options)
                   if typing.get_origin(hints[f.name]) is typing.Literal}
        for combo in itertools.product(*choices.values()):
            yield m, m.options(**dict(zip(choices, combo, strict=True)))


def test_every_method_and_variant_has_its_own_style():
    """Reference: the registry itself: Method.style_for of every method and Literal variant gives
    a distinct (colour, marker, line style), and no method takes a reference's colour."""
    styles = [m.style_for(o) for m, o in _variants()]
    assert len(styles) >= len(METHODS) + 5  # obe: 2 forms x 3 criteria
    assert len(set(styles)) == len(styles)
    assert not {s.color for s in styles} & set(PALETTE.values())


def test_figure_colours_come_from_the_method_styles():
    """Reference: Method.style_for: a figure label naming a study's estimator label (alone, or
    followed by " / regression" or " (unverified)") takes that estimator's style; references keep
    their PALETTE colour; other labels a stable colour."""
    fac = METHODS["obe"].style_for(METHODS["obe"].options(form="factorized"))
    std = METHODS["obe"].style_for(METHODS["obe"].options(form="standard"))
    with method_styles({"OBE": fac, "OBE-std": std, "RLS": METHODS["rls"].style_for()}):
        assert style_for("OBE / filtered_dynamic") == style_for("OBE (unverified)") == fac
        assert color_for("OBE-std") == std.color != fac.color
        assert color_for("RLS / supplied_energy") == METHODS["rls"].style.color
    assert color_for("SDP outer") == PALETTE["SDP outer"] and color_for("LP exact") == PALETTE["LP exact"]
    assert color_for("OBE") == color_for("OBE")  # outside the block: a fixed colour by its hash


# ------------------------------------------------------------------------------------ figures
def test_parameter_convergence_draws_each_history_and_truth():
    """Reference: the input arrays: one axis per parameter, each line's y-data equals the history
    centres, x-data equals t[index], and the truth line sits at the true value."""
    t = np.arange(100) * 0.01
    hists = {"OBE-factorized (volume)": _history(seed=1), "RLS": (_history(seed=2).index, _history(seed=2).centers)}
    obe = METHODS["obe"].style_for()
    with method_styles({"OBE-factorized": obe}):
        fig = parameter_convergence(t, hists, TRUTH, NAMES, units=["kg", "kg m^2", "N m s"])
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    h = hists["OBE-factorized (volume)"]
    for j, ax in enumerate(fig.axes):
        line = ax.lines[0]
        np.testing.assert_array_equal(line.get_ydata(), h.centers[:, j])
        np.testing.assert_array_equal(line.get_xdata(), t[h.index])
        assert line.get_color().lower() == obe.color.lower()
        assert np.allclose(ax.lines[-1].get_ydata(), TRUTH[j])  # the dashed truth line
    assert fig.axes[1].get_ylabel() == "I^2 [kg m^2]"
    thinned = parameter_convergence(t, {"RLS": h}, max_points=10)  # 30 points -> every 3rd
    np.testing.assert_array_equal(thinned.axes[2].lines[0].get_ydata(), h.centers[::3, 2])


def test_parameter_convergence_rejects_mismatched_histories():
    """Reference: the documented contract (every history has the same p, names match p)."""
    with pytest.raises(InputError):
        parameter_convergence(None, {"a": _history(p=3), "b": _history(p=2)})
    with pytest.raises(InputError):
        parameter_convergence(None, {"a": _history(p=3)}, names=["x", "y"])
    with pytest.raises(InputError, match="time vector"):
        parameter_convergence(np.arange(5.0), {"a": _history(p=3)})


def test_torque_bounds_counts_samples_outside_the_band():
    """Reference: samples placed outside the band by construction (indices 7 and 30 on joint 2,
    none on joint 1) must be the ones marked and counted."""
    N = 50
    t = np.linspace(0, 1, N)
    center = np.column_stack([np.sin(t), np.cos(t)])
    hw = np.full((N, 2), 0.1)
    measured = center + 0.05
    measured[[7, 30], 1] = center[[7, 30], 1] + 0.3
    fig = torque_bounds(t, measured, center - hw, center + hw, "OBE-factorized",
                        {"WLS 95 %": (center - 0.5 * hw, center + 0.5 * hw)}, joint_names=["q1", "q2"])
    assert len(fig.axes) == 2
    assert "0 of 50" in fig.axes[0].get_title() and "2 of 50" in fig.axes[1].get_title()
    marks = [ln for ln in fig.axes[1].lines if ln.get_marker() == "x"]
    assert len(marks) == 1
    np.testing.assert_array_equal(marks[0].get_xdata(), t[[7, 30]])
    with pytest.raises(InputError):
        torque_bounds(t, measured, center[:, :1], center + hw)
    with pytest.raises(InputError):
        torque_bounds(t, measured, center + hw, center - hw)


def test_torque_bounds_thins_long_records_but_marks_every_outlier():
    """Reference: a 20 000-sample record with max_points=1000 draws every 20th sample, while the
    single out-of-band sample (index 12345, not a multiple of 20) is still marked."""
    N = 20_000
    t = np.arange(N) * 1e-3
    y = np.zeros(N)
    y[12345] = 1.0
    fig = torque_bounds(t, y, np.full(N, -0.5), np.full(N, 0.5), max_points=1000)
    ax = fig.axes[0]
    measured_line = next(ln for ln in ax.lines if ln.get_label() == "measured")
    assert len(measured_line.get_xdata()) == 1000
    marks = next(ln for ln in ax.lines if ln.get_marker() == "x")
    np.testing.assert_array_equal(marks.get_xdata(), [t[12345]])


def test_trajectory_comparison_shows_positions_and_errors():
    """Reference: the inputs: 2 n axes; the error column holds q_resim - q_measured."""
    t = np.linspace(0, 1, 40)
    qm = np.column_stack([np.sin(t), t**2])
    fig = trajectory_comparison(t, qm, {"WLS": qm + 0.01, "OBE-factorized": qm - 0.02})
    assert len(fig.axes) == 4
    err_ax = fig.axes[1]  # row 0, error column
    np.testing.assert_allclose(err_ax.lines[1].get_ydata(), 0.01)
    np.testing.assert_allclose(err_ax.lines[2].get_ydata(), -0.02)
    with pytest.raises(InputError):
        trajectory_comparison(t, qm, {"WLS": qm[:, :1]})


def test_projection_2d_draws_the_polygon_and_the_set_boundaries():
    """References: the convex hull of a square's corners plus interior points is the square
    (closed form); every drawn ellipse point has Mahalanobis distance 1 (Ellipsoid.mahalanobis2);
    a box is drawn by its four corners."""
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    pts = np.vstack([corners, np.random.default_rng(0).uniform(0.2, 0.8, (10, 2))])
    E = Ellipsoid([0.5, 0.5], [[0.5, 0.1], [0.1, 0.3]])
    sets = {"SDP outer": E, "John": E.scaled(0.4), "Box": Box([0.1, 0.2], [0.9, 0.8])}
    fig = projection_2d(VertexPolytope(pts), sets, [0.5, 0.5], ([0, 0], [1, 1]), ["a", "b"])
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    polygon = ax.patches[0].get_xy()
    assert {tuple(v) for v in np.round(polygon, 12)} == {tuple(v) for v in corners}
    boundary = ax.lines[0].get_xydata()
    np.testing.assert_allclose(E.mahalanobis2(boundary), 1.0, rtol=1e-9)
    box_line = next(ln for ln in ax.lines if ln.get_label() == "Box").get_xydata()
    assert {tuple(v) for v in box_line} == {(0.1, 0.2), (0.9, 0.2), (0.9, 0.8), (0.1, 0.8)}
    with pytest.raises(InputError, match="2-D"):
        projection_2d(None, {"3-D": Ellipsoid.ball(np.zeros(3), 1.0)})


def test_projection_2d_frames_the_exact_set_not_a_far_wider_one():
    """Reference: the unit square's shadow (closed form). A box 1000 x wider does not set the limits
    (everything else would be a dot); it is drawn, and its legend entry says it is off the frame."""
    square = VertexPolytope(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    sets = {"Box": Box([-500.0, -500.0], [500.0, 500.0]), "OBE": Ellipsoid.ball([0.5, 0.5], 1.0)}
    ax = projection_2d(square, sets, [0.5, 0.5], ([0, 0], [1, 1]), ["a", "b"]).axes[0]
    assert ax.get_xlim()[1] - ax.get_xlim()[0] < 3.0 and ax.get_ylim()[1] - ax.get_ylim()[0] < 3.0
    labels = [ln.get_label() for ln in ax.lines]
    assert "Box (off frame)" in labels and "OBE" in labels


def test_width_ratios_dots_are_width_over_exact_width():
    """Reference: hand-computed ratios 1.5, 2 (outer) and 0.5 (inner) of given widths: one dot per
    estimate and parameter, at x = ratio on a log axis; the reference is the line at 1."""
    df = pd.DataFrame({"LP exact": [2.0, 1.0], "OBE-factorized": [3.0, 2.0], "John": [1.0, 0.5]},
                      index=pd.Index(["a", "b"], name="parameter"))
    fig = width_ratios(df)
    ax = fig.axes[0]
    assert len(fig.axes) == 1 and ax.get_xscale() == "log"
    dots = {ln.get_label(): ln.get_xdata() for ln in ax.lines if ln.get_linestyle() == "None"}
    np.testing.assert_allclose(dots["OBE-factorized"], [1.5, 2.0])
    np.testing.assert_allclose(dots["John"], [0.5, 0.5])
    with pytest.raises(InputError, match="reference"):
        width_ratios(df.drop(columns="LP exact"))


def test_log_volume_bars_and_volume_history():
    """Reference: the inputs: bar lengths equal the given values, NaN (point estimates) left out;
    a history of all-NaN volumes is skipped and the others drawn unchanged."""
    fig = log_volume_bars({"OBE-factorized": -1.5, "SDP outer": -2.0, "RLS": float("nan")})
    assert len(fig.axes) == 1
    np.testing.assert_allclose([r.get_width() for r in fig.axes[0].patches], [-1.5, -2.0])
    h = _history()
    nan_hist = (h.index, np.full(len(h), np.nan))
    fig = volume_history({"OBE-standard": h, "RLS": nan_hist})
    assert len(fig.axes) == 1 and len(fig.axes[0].lines) == 1
    np.testing.assert_array_equal(fig.axes[0].lines[0].get_ydata(), h.log_volumes)
    with pytest.raises(InputError):
        volume_history({"RLS": nan_hist})


# ------------------------------------------------------------------------------------- tables
def test_parameter_table_keeps_numbers_and_formats_intervals():
    """Reference: the inputs; the CSV round trip (pandas.read_csv) returns the numbers exactly,
    the display frame shows "[lo, hi]"."""
    lo, hi = TRUTH - 0.25, TRUTH + 0.5
    df = parameter_table(NAMES, {"truth": TRUTH, "LP exact": (lo, hi)})
    assert list(df.columns) == ["truth", "LP exact lo", "LP exact hi"]
    text = format_frame(df, "{:.3g}")
    assert list(text.columns) == ["truth", "LP exact"]
    assert text.loc["m_1", "LP exact"] == "[1.75, 2.5]"
    buf = io.StringIO()
    df.to_csv(buf)
    back = pd.read_csv(io.StringIO(buf.getvalue()), index_col=0)
    np.testing.assert_array_equal(back["LP exact lo"].to_numpy(), lo)
    with pytest.raises(InputError, match="lo > hi"):
        parameter_table(NAMES, {"bad": (hi, lo)})
    with pytest.raises(InputError):
        parameter_table(NAMES, {"short": TRUTH[:2]})


def test_deviation_percent_and_widths():
    """Reference: hand-computed percentages; zero truth gives NaN (undefined)."""
    dev = deviation_percent({"a": np.array([2.2, 0.45, 0.0]), "b": _estimate("b")}, [2.0, 0.5, 0.0], NAMES)
    np.testing.assert_allclose(dev["a"].to_numpy()[:2], [10.0, -10.0])
    assert np.isnan(dev["a"].iloc[2])
    np.testing.assert_allclose(dev["b"].to_numpy()[:2], [2.5, 10.0])
    w = widths(NAMES, {"x": (np.zeros(3), np.array([1.0, 2.0, 3.0]))})
    np.testing.assert_array_equal(w["x"].to_numpy(), [1.0, 2.0, 3.0])


def test_estimate_summary_against_closed_forms():
    """Reference: ln vol of a 3-D ball of radius r is ln(4/3 pi r^3); truth containment decided by
    hand (the ball of radius 0.3 about truth + 0.05 contains truth, of radius 0.04 does not, nor its intervals)."""
    ests = {"OBE-factorized": _estimate("OBE-factorized"), "tight": _estimate("tight", 0.04)}
    ref = (TRUTH - 0.3, TRUTH + 0.3)
    s = estimate_summary(ests, TRUTH, ref)
    assert s.loc["OBE-factorized", "ln vol"] == pytest.approx(np.log(4 / 3 * np.pi * 0.3**3))
    assert s.loc["OBE-factorized", "ln vol / p"] == pytest.approx(np.log(4 / 3 * np.pi * 0.3**3) / 3)
    assert s.loc["OBE-factorized", "mean width / exact"] == pytest.approx(1.0)
    assert s.loc["OBE-factorized", "truth in set"] == "yes" and s.loc["tight", "truth in set"] == "no"
    assert s.loc["tight", "truth in intervals"] == "no"


def test_markdown_and_latex_escape_and_align():
    """Reference: tabulate's LaTeX escapes (_ -> \\_, ^ -> \\^{}, % -> \\%) and Markdown pipes."""
    df = parameter_table(NAMES, {"truth": TRUTH})
    md = markdown_table(df)
    assert md.splitlines()[0].startswith("| parameter") and "m_1" in md and "--:|" in md
    tex = latex_table(df, caption="Deviation [%] of m_1", label="tab:x")
    assert "\\begin{tabular}" in tex and "\\toprule" in tex and "m\\_1" in tex and "I\\^{}2" in tex
    assert "\\caption{Deviation [\\%] of m\\_1}" in tex


# -------------------------------------------------------------------------------------- pages
class _PageParser(HTMLParser):
    def __init__(self):
        super().__init__()
        self.imgs, self.urls, self.tables, self.captions, self.scripts = [], [], 0, [], 0
        self._in_caption = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.imgs.append(a)
        for key in ("src", "href"):
            if key in a:
                self.urls.append(a[key])
        self.tables += tag == "table"
        self.scripts += tag == "script"
        if tag == "figcaption":
            self._in_caption = True
            self.captions.append("")

    def handle_endtag(self, tag):
        if tag == "figcaption":
            self._in_caption = False

    def handle_data(self, data):
        if self._in_caption:
            self.captions[-1] += data


@pytest.fixture(scope="module")
def study_page(tmp_path_factory):
    root = tmp_path_factory.mktemp("reports")
    ests = {"OBE-factorized (volume)": _estimate("OBE-factorized (volume)"),
            "WLS": _estimate("WLS", 0.2, "statistical")}
    t = np.linspace(0, 1, 60)
    page = Page("Toy study <1>", "A toy set-up & three parameters.\n\nSecond paragraph.",
                setup={"robot": "toy", "samples": 60})
    page.section("Parameters", "Intervals of each estimate.")
    page.table(parameter_table(NAMES, {"truth": TRUTH, **{k: e.intervals for k, e in ests.items()}}), "Intervals")
    page.table(estimate_summary(ests, TRUTH), "Summary", "{:.3f}")
    page.figure(parameter_convergence(t, {k: e.history for k, e in ests.items()}, TRUTH, NAMES), "Convergence")
    page.section("Sets").figure(log_volume_bars({k: e.set.log_volume() / 3 for k, e in ests.items()}), "Volumes")
    path = page.write(root / "toy" / "index.html")
    return root, path


def test_page_is_self_contained(study_page):
    """Reference: the page parsed by html.parser; every <img> is a base64 PNG (PNG signature,
    decoded by PIL to a non-empty image), no http(s) URL anywhere, no script, under 3 MB."""
    _, path = study_page
    text = path.read_text(encoding="utf-8")
    parser = _PageParser()
    parser.feed(text)
    assert len(parser.imgs) == 2 and parser.tables == 2 and parser.scripts == 0
    for img in parser.imgs:
        prefix = "data:image/png;base64,"
        assert img["src"].startswith(prefix)
        png = base64.b64decode(img["src"][len(prefix) :], validate=True)
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        with Image.open(io.BytesIO(png)) as im:
            im.load()
            assert im.width > 100 and im.height > 100
    assert not [u for u in parser.urls if re.match(r"(?i)\s*(https?:)?//", u)]
    assert "http://" not in text and "https://" not in text
    assert path.stat().st_size < 3_000_000
    assert "Toy study &lt;1&gt;" in text and "A toy set-up &amp; three parameters." in text
    assert [c.split(".")[0] for c in parser.captions] == ["Table 1", "Table 2", "Figure 1", "Figure 2"]


def test_page_writes_figures_tables_and_summary(study_page):
    """Reference: the files read back: PNG/SVG per figure (PNG equal to the embedded one), CSV
    numeric (read by pandas), LaTeX with a tabular, summary.md with every caption and table."""
    root, path = study_page
    d = path.parent
    assert sorted(p.name for p in (d / "figures").iterdir()) == [
        "convergence.png", "convergence.svg", "volumes.png", "volumes.svg"]
    embedded = re.search(r'src="data:image/png;base64,([^"]+)"', path.read_text()).group(1)
    assert base64.b64decode(embedded) == (d / "figures" / "convergence.png").read_bytes()
    assert (d / "figures" / "convergence.svg").read_text().lstrip().startswith("<?xml")
    csv = pd.read_csv(d / "tables" / "intervals.csv", index_col=0)
    np.testing.assert_array_equal(csv["truth"].to_numpy(), TRUTH)
    assert "WLS lo" in csv.columns
    assert "\\begin{tabular}" in (d / "tables" / "summary.tex").read_text()
    md = (d / "summary.md").read_text()
    for s in ("# Toy study &lt;1&gt;", "## Parameters", "**Table 1.** Intervals", "**Table 2.** Summary",
              "![Figure 1. Convergence](figures/convergence.png)", "| parameter"):
        assert s in md


def test_write_index_links_every_study(study_page):
    """Reference: the written index parsed by html.parser: one link per study page, with the
    study page's own title read back from it."""
    root, _ = study_page
    out = write_index(root, home=None)
    parser = _PageParser()
    parser.feed(out.read_text())
    assert parser.urls == ["toy/index.html"]
    parser = _PageParser()
    parser.feed(write_index(root).read_text())  # a group index links back to the site index above it
    assert parser.urls == ["../index.html", "toy/index.html"]
    assert "Toy study &lt;1&gt;" in out.read_text()
    assert "A toy set-up &amp; three parameters." in out.read_text()  # the page's meta description
    out = write_index(root, [("toy", "Given title", "toy/index.html")])
    assert "Given title" in out.read_text() and "Toy study" not in out.read_text()
    with pytest.raises(InputError, match="does not exist"):
        write_index(root, ["missing"])
    with pytest.raises(InputError, match="entry"):
        write_index(root, [("toy",)])


def test_page_size_limit_and_input_checks(tmp_path):
    """Reference: the documented contract: too large a page and non-Figure/non-DataFrame inputs raise."""
    page = Page("big", max_bytes=1000).figure(log_volume_bars({"a": 1.0}), "one figure")
    with pytest.raises(InputError, match="MB"):
        page.write(tmp_path / "index.html")
    assert not (tmp_path / "index.html").exists()
    with pytest.raises(InputError):
        Page("x").figure("not a figure", "c")
    with pytest.raises(InputError):
        Page("x").table(np.zeros((2, 2)), "c")


# ------------------------------------------------------------------------------------ browser
needs_browser = pytest.mark.skipif(browser.find_browser() is None, reason="no Chromium installed")


@needs_browser
@pytest.mark.slow
def test_browser_check_passes_good_page_and_catches_broken_ones(study_page, tmp_path):
    """Reference: Chromium itself. The generated page passes; negative controls fail: a corrupted
    base64 PNG (broken image), a throwing script, and an external image URL (blocked by the CSP)."""
    _, path = study_page
    exe = browser.find_browser()
    assert browser.check_page(path, exe) == []
    text = path.read_text()
    broken = tmp_path / "broken.html"
    broken.write_text(text.replace("data:image/png;base64,iVBOR", "data:image/png;base64,AAAAA", 1))
    assert any("broken image" in p for p in browser.check_page(broken, exe))
    external = tmp_path / "external.html"
    external.write_text(text.replace("</main>", '<img src="http://example.invalid/x.png" alt="ext"></main>'))
    problems = browser.check_page(external, exe)
    assert any("broken image: ext" in p for p in problems) and any("CSP" in p for p in problems)
    script = tmp_path / "script.html"
    script.write_text(text.replace("<head>", "<head><script>undefinedFunction();</script>", 1))
    assert any("script error" in p for p in browser.check_page(script, exe))
    assert browser.main([str(path.parent)]) == 0  # the command over a folder: one good page
    assert browser.main([str(tmp_path)]) == 2  # no index.html there: nothing to check is an error


def test_format_frame_keeps_text_columns_with_an_integer_index():
    """Text columns survive format_frame whatever the index type (they used to become NaN)."""
    import pandas as pd

    from boundid.report.tables import format_frame

    df = pd.DataFrame({"kind": ["a", "b"], "x": [1.0, 2.0]}, index=[0, 1])
    out = format_frame(df)
    assert out["kind"].tolist() == ["a", "b"]


def test_the_same_figure_gives_the_same_svg_file():
    """matplotlib salts an SVG's element ids at random; the page fixes the salt, so a figure
    drawn twice gives byte-identical SVGs (reports regenerated from the same numbers do not
    change in git)."""
    svgs = []
    for _ in range(2):
        page = Page("t", "t")
        page.section("s")
        fig = Figure()
        fig.add_subplot().plot([0, 1, 2], [1, 0, 1])
        page.figure(fig, "a figure", name="f")
        svgs.append(page._sections[-1].blocks[-1].svg)
    assert b"clip-path" in svgs[0] and svgs[0] == svgs[1]


def test_prose_columns_are_left_aligned_and_wrapped():
    """A column with a sentence in it is marked prose (left-aligned, wrapped), so that the short values
    beside it stay in view; a column of short words (the keyed label column here) is left-aligned as
    "words"; numeric columns are neither."""
    from boundid.report.html import PROSE_CHARS, Page

    page = Page("t")
    page.section("s")
    df = pd.DataFrame({"value": ["short", "x" * (PROSE_CHARS + 1)], "n": [1.0, 2.0]},
                      index=pd.Index(["a", "b"], name="setting"))
    page.table(df, "caption", name="setup")
    html = page.to_html()
    table = html[html.index('id="tab-setup"'):]
    assert table.count('<td class="prose">') == 2 and table.count('<th class="prose">') == 1
    assert '<td class="words">a</td>' in table and "<td>1</td>" in table


def test_position_step_is_the_encoders_resolution():
    """A 12-bit encoder's angles (2 pi / 4096 = 1.5e-3 rad a count) at h = 1 ms: the smallest step and
    its 1.5 rad/s over one period."""
    from boundid.experiments.recording import Recording
    from boundid.report.study_page import position_step_text

    t = np.arange(2000) * 1e-3
    count = 2 * np.pi / 4096
    q = np.round(np.c_[np.sin(t), 0.3 * np.cos(2 * t)] / count) * count
    text = position_step_text(Recording(t, q, np.c_[t, t]))
    assert text.startswith("0.0015, 0.0015 rad by joint") and "over one sample period 1.5, 1.5 rad/s" in text


def test_the_header_files_may_wrap():
    """The header's file links are separated by spaces, so that a page with many files (the TX40's exports:
    nine) wraps them instead of scrolling sideways as a whole."""
    from boundid.report.html import site_header

    header = site_header("t", "../index.html", files=[(f"file{k}.csv", f"file{k}.csv") for k in range(9)])
    assert header.count("</a> <a") == 8
