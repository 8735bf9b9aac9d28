"""The browser check itself, on pages built here with known defects (``make test-browser`` only:
it needs Chromium, so these tests carry the ``browser`` mark that ``make test`` leaves out).

Reference: each page below is either clean by construction (a boundid Page whose wide table sits in
the scrolling, shadowed wrapper; a Handout stepper with 1000 px frames) or has exactly one defect
put in by hand (a wide table in a box that does not scroll, one that scrolls without a cue, an
image that does not decode, a stepper whose script the Content-Security-Policy blocks, frames
600 px wide); the check must pass the first and name the defect of each of the others.
"""

import pandas as pd
import pytest
from matplotlib.figure import Figure

from boundid.report import Page
from boundid.report.browser import check_page, find_browser
from boundid.teaching import Handout

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(find_browser() is None, reason="needs Chromium (make test-browser installs it)")]

WIDE = pd.DataFrame({f"a rather long column name {k}": [1.234567 * k] for k in range(16)},
                    index=pd.Index(["row"], name="r"))


def _check(tmp_path, page, name="index.html", shots=False):
    out = page.write(tmp_path / name) if hasattr(page, "write") else page
    return check_page(out, find_browser(), tmp_path / "shots" if shots else None, "page")


def test_a_wide_table_in_the_scrolling_shadowed_box_passes_and_screenshots_are_written(tmp_path):
    problems = _check(tmp_path, Page("wide").section("s", "text").table(WIDE, "wide", name="wide"), shots=True)
    assert problems == []
    for shot in ("page.png", "page-full.png"):
        assert (tmp_path / "shots" / shot).stat().st_size > 1000


def test_a_wide_table_in_a_box_that_does_not_scroll_fails(tmp_path):
    out = Page("wide").section("s", "text").table(WIDE, "wide", name="wide").write(tmp_path / "index.html")
    out.write_text(out.read_text().replace('<div class="scroll">', '<div class="plain">'))
    problems = _check(tmp_path, out)
    assert any("that does not scroll" in p for p in problems)


def test_a_scrolling_table_without_a_cue_fails(tmp_path):
    out = Page("wide").section("s", "text").table(WIDE, "wide", name="wide").write(tmp_path / "index.html")
    out.write_text(out.read_text().replace('<div class="scroll">', '<div style="overflow-x: auto">'))
    problems = _check(tmp_path, out)
    assert any("scrolls without a visible scroll cue" in p for p in problems)


def test_a_broken_image_fails(tmp_path):
    out = Page("img").section("s", "text").write(tmp_path / "index.html")
    out.write_text(out.read_text().replace("<p>text</p>", '<p>text</p><img alt="not a png" '
                                                           'src="data:image/png;base64,AAAAAAAA">'))
    assert "broken image: not a png" in _check(tmp_path, out)


def _frames(width_in):
    figs = []
    for k in range(3):
        fig = Figure(figsize=(width_in, 3.0), layout="constrained")
        fig.subplots().plot([0, 1], [0, k])
        figs.append(fig)
    return figs


def test_a_stepper_steps_and_a_blocked_or_small_one_fails(tmp_path):
    handout = Handout("h").section("s", "text").stepper(_frames(10.0), ["a", "b", "c"], "frames", name="f")
    assert _check(tmp_path, handout) == []
    out = tmp_path / "index.html"
    text = out.read_text()
    out.write_text(text.replace("; script-src 'sha256-", "; script-src 'sha256-X"))  # the CSP now blocks it
    problems = _check(tmp_path, out)
    assert any("Content Security Policy" in p for p in problems) and any("does not step" in p for p in problems)
    assert any("does not play" in p for p in problems)
    small = Handout("h").section("s", "text").stepper(_frames(6.0), ["a", "b", "c"], "frames", name="f")
    assert any("under 800 px" in p for p in _check(tmp_path, small, "small.html"))
