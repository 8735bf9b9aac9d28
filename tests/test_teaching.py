"""The teaching kit: every lesson runs as a plain script (fast settings) and writes a handout whose
sentences agree with its own tables.

References: the lesson scripts run in a fresh interpreter (as a student would run them); each
handout is checked with independent readers: Python's html.parser for the page structure,
Pillow for every embedded image (it must decode), hashlib for the script hash in the page's
Content-Security-Policy, a regular expression for network URLs (the page must be
self-contained), jupytext (when installed) for the notebook form. The claims of each lesson's
text are read back with regular expressions from ``summary.md`` and compared with the numbers of
the CSV tables the same run wrote (pandas), so a sentence that contradicts its table fails.
"""

import base64
import hashlib
import io
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure
from PIL import Image

from boundid.errors import InputError, StudyError
from boundid.teaching import Handout, lessons, run_lesson, run_lessons, series_style

ROOT = Path(__file__).resolve().parents[1]
LESSONS = lessons(ROOT / "studies" / "teaching")


class _Page(HTMLParser):
    """Images (src, width attribute, stepper frame or not), scripts, and the CSP of a page."""

    def __init__(self):
        super().__init__()
        self.imgs, self.scripts, self.csp, self._script = [], [], "", None
        self._stepper_depth, self._depth = None, 0
        self.steppers = 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self._depth += 1
        if tag == "figure" and "stepper" in (a.get("class") or "").split():
            self._stepper_depth, self.steppers = self._depth, self.steppers + 1
        if tag == "img":
            self.imgs.append((a["src"], a.get("width"), self._stepper_depth is not None))
        if tag == "script":
            self._script = ""
        if tag == "meta" and a.get("http-equiv") == "Content-Security-Policy":
            self.csp = a["content"]
        if tag in ("img", "meta", "input", "br"):  # void elements
            self._depth -= 1

    def handle_endtag(self, tag):
        if tag == "figure" and self._stepper_depth == self._depth:
            self._stepper_depth = None
        if tag == "script":
            self.scripts.append(self._script)
            self._script = None
        self._depth -= 1

    def handle_data(self, data):
        if self._script is not None:
            self._script += data


def _check_page(page: Path) -> _Page:
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"(src|href)=\"(https?:)?//", text), "the handout loads something from the network"
    assert "http://" not in text.replace("http://www.w3.org", "") and "https://" not in text
    parsed = _Page()
    parsed.feed(text)
    assert parsed.imgs, "a handout shows at least one figure"
    for src, _, _ in parsed.imgs:
        m = re.fullmatch(r"data:image/(png|gif);base64,([A-Za-z0-9+/=]+)", src)
        assert m, f"image not embedded as base64 PNG/GIF: {src[:60]}"
        img = Image.open(io.BytesIO(base64.b64decode(m.group(2), validate=True)))
        img.load()
        assert img.format.lower() == m.group(1)
    for script in parsed.scripts:  # every script runs only because the CSP names its hash
        digest = base64.b64encode(hashlib.sha256(script.encode("utf-8")).digest()).decode()
        assert f"'sha256-{digest}'" in parsed.csp
    assert 'class="keypoints"' in text, "the handout opens with its key points"
    assert text.count('<ol class="exercises">') == 1 and text.count('<details class="key">') == 1
    questions = re.search(r'<ol class="exercises">(.*?)</ol>', text, re.S).group(1).count("<li>")
    answers = re.search(r'<details class="key">(.*?)</details>', text, re.S).group(1).count("<b>Answer.</b>")
    assert questions == answers >= 2, "every exercise has its answer in the instructor key"
    return parsed


# ------------------------------------------------------------------------------ text vs tables
def _md(page: Path) -> str:
    return " ".join((page.parent / "summary.md").read_text(encoding="utf-8").split())


def _csv(page: Path, name: str, **kw) -> pd.DataFrame:
    return pd.read_csv(page.parent / "tables" / f"{name}.csv", **kw)


def _num(text: str) -> float:
    return float(text.rstrip("%")) / (100.0 if text.endswith("%") else 1.0)


def _close(stated: str, value: float, digits: int = 3) -> bool:
    """A number written with ``digits`` significant digits (or as a rounded percentage) matches."""
    x = _num(stated)
    if stated.endswith("%"):
        return abs(x - value) <= 0.005 + 1e-12
    return abs(x - value) <= 0.5 * 10 ** (np.floor(np.log10(abs(value) or 1.0)) - digits + 1) * 1.0001


def _claims_lesson1(page: Path):
    md, areas = _md(page), _csv(page, "areas", index_col=0)
    n_vertices = len(_csv(page, "vertices"))
    m = re.search(r"strips leave a polygon with (\d+) vertices", md)
    assert int(m.group(1)) == n_vertices
    inside = areas.loc["polygon P (exact)", "contains truth"]
    assert ("The truth lies inside the polygon" in md) == bool(inside)
    for label in ("LP bounding box", "SDP outer", "John (2 x inner)"):
        m = re.search(re.escape(label) + r" ([\d.]+)x[ ,]", md)
        assert _close(m.group(1), areas.loc[label, "area / area(P)"])
    m = re.search(r"largest inscribed ellipse covers (\d+%) of it, the Chebyshev disc (\d+%)", md)
    assert _close(m.group(1), areas.loc["inner (max volume)", "area / area(P)"])
    assert _close(m.group(2), areas.loc["Chebyshev disc", "area / area(P)"])
    bounds = _csv(page, "bounds", index_col=0)
    m = re.search(r"J in \[([\d.]+), ([\d.]+)\] kg m²", md)
    assert _close(m.group(1), bounds.loc["J", "LP lo"], 4) and _close(m.group(2), bounds.loc["J", "LP hi"], 4)


def _claims_lesson2(page: Path):
    md, steps = _md(page), _csv(page, "steps", index_col=0)
    counts = steps["event"].value_counts()
    m = re.search(r"updated its ellipse on (\d+), skipped (\d+) that did not cut it usefully and flagged (\d+)", md)
    assert [int(g) for g in m.groups()] == [counts.get(e, 0) for e in ("update", "skipped", "outlier")]
    m = re.search(r"injected gross error \(strip (\d+)\) was (caught|NOT caught)", md)
    assert (steps.loc[int(m.group(1)), "event"] == "outlier") == (m.group(2) == "caught")
    upd = steps[steps["event"] == "update"]
    gap = float(np.max(np.abs(upd["ln area OBE"] - upd["ln area SDP optimum"])))
    m = re.search(r"to within (\d\.\de[+-]\d+)", md)
    assert m and _close(m.group(1), gap, 2)
    assert ("The truth stayed inside every ellipse" in md) == bool(steps["truth inside"].all())
    order = _csv(page, "order", index_col=0)
    m = re.search(r"(\d+) orders give ln areas from (-?\d+\.\d+) to (-?\d+\.\d+)", md)
    assert int(m.group(1)) == len(order)
    assert abs(float(m.group(2)) - order["ln area"].min()) <= 0.005
    assert abs(float(m.group(3)) - order["ln area"].max()) <= 0.005


def _claims_lesson3(page: Path):
    md, forms, cond = _md(page), _csv(page, "forms", index_col=0), _csv(page, "conditioning", index_col=0)

    def stated_range(text):
        m = re.fullmatch(r"about ([\d.e+-]+)|([\d.e+-]+) to ([\d.e+-]+)", text)
        lo, hi = (m.group(1), m.group(1)) if m.group(1) else (m.group(2), m.group(3))
        return float(lo), float(hi)

    rng = r"((?:about )?[\d.]+e[+-]\d+(?: to [\d.]+e[+-]\d+)?)"
    m = re.search(r"cond\(W\) of the first (\d+) rows is " + rng + ", of all rows " + rng, md)
    for text, col in ((m.group(2), f"cond(first {m.group(1)} rows)"), (m.group(3), "cond(all rows)")):
        lo, hi = stated_range(text)
        assert _close(f"{lo:.1e}", cond[col].min(), 2) and _close(f"{hi:.1e}", cond[col].max(), 2)
    for form in ("Standard", "Factorized"):
        rows = forms[forms.index.str.startswith(form.lower())]
        m = re.search(form + r" form: .*?final status ((?:\d+ \w+(?:, )?)+)", md)
        stated = dict((k, int(n)) for n, k in re.findall(r"(\d+) (\w+)", m.group(1)))
        assert stated == rows["final status"].value_counts().to_dict()
    fac = forms[forms.index.str.startswith("factorized")]
    assert ("Factorized form: no breakdown on any seed" in md) == bool((fac["breakdowns"] == 0).all())
    inside = bool((fac["truth Mahalanobis²"] <= 1).all())
    assert (("the truth is inside its own set on every seed" in md) == inside)


def _claims_lesson4(page: Path):
    md, cov = _md(page), _csv(page, "coverage", index_col=0)
    m = re.search(r"the OBE contains the truth in (\d+%) of (\d+) experiments, OLS in (\d+%)", md)
    assert _close(m.group(1), cov.loc["uniform bounded", "OBE coverage"])
    assert _close(m.group(3), cov.loc["uniform bounded", "OLS coverage"])
    m = re.search(r"Gaussian noise makes the exact set empty in (\d+%) .*? falls to (\d+%); OLS keeps (\d+%)", md)
    assert _close(m.group(1), cov.loc["Gaussian", "exact set empty"])
    assert _close(m.group(2), cov.loc["Gaussian", "OBE coverage"])
    assert _close(m.group(3), cov.loc["Gaussian", "OLS coverage"])
    for kind in ("friction", "spring"):
        m = re.search(kind + r"[^.;]*? gives OBE (\d+%), OLS (\d+%)", md)
        assert _close(m.group(1), cov.loc[kind, "OBE coverage"]) and _close(m.group(2), cov.loc[kind, "OLS coverage"])


def _claims_lesson5(page: Path):
    md, models = _md(page), _csv(page, "models", index_col=0)
    inertia = "Inertia and gravity terms \\(th1..th5\\): mean absolute deviation "
    for head, col in ((inertia, "mean abs dev th1..th5 [%]"), ("Friction terms: ", "mean abs dev friction [%]")):
        m = re.search(head + r"(.+?); the (.+?) model is the worst", md)
        stated = dict((name, float(v)) for name, v in re.findall(r"([a-z ]+?) ([\d.]+) %(?:, )?", m.group(1)))
        assert set(stated) == set(models.index)
        for name, v in stated.items():
            assert _close(str(v), models.loc[name, col])
        assert m.group(2) == models[col].idxmax()
    dev = _csv(page, "deviation", index_col=0)
    m = re.search(r"The largest single deviation is (\w+) by the (.+?) model \(([-+\d.e]+) %\)", md)
    param, model = dev.abs().stack().idxmax()
    assert (m.group(1), m.group(2)) == (param, model) and _close(m.group(3), dev.loc[param, model])


def _claims_lesson6(page: Path):
    md, crit, sets = _md(page), _csv(page, "criteria", index_col=0), _csv(page, "sets", index_col=0)
    m = re.search(r"cond\(W\) = ([\d.]+) for A and ([\d.]+) for B \(relative gap ([\d.e+-]+);", md)
    assert _close(m.group(1), crit.loc["A", "cond(W)"], 7) and _close(m.group(2), crit.loc["B", "cond(W)"], 7)
    gap = abs(crit.loc["B", "cond(W)"] / crit.loc["A", "cond(W)"] - 1)
    assert float(m.group(3)) <= 1e-9 and gap <= 1e-9 and "NOT equal" not in md
    m = re.search(r"A's (\d+) strips point in (\d+) directions, B's in (\d+)", md)
    assert [int(g) for g in m.groups()[1:]] == list(crit["strip directions"])
    m = re.search(r"B's feasible polygon has area ([\d.e+-]+) against ([\d.e+-]+) for A \(([\d.]+)x", md)
    assert _close(m.group(1), sets.loc["B", "area"]) and _close(m.group(2), sets.loc["A", "area"])
    assert _close(m.group(3), sets.loc["B", "area"] / sets.loc["A", "area"])
    assert np.allclose(sets["area"], sets["area (Polytope.volume)"], rtol=1e-6)
    m = re.search(r"LP widths ([\d.]+)x \(J\) and ([\d.]+)x \(mgl\)", md)
    assert _close(m.group(1), sets.loc["B", "J width"] / sets.loc["A", "J width"])
    assert _close(m.group(2), sets.loc["B", "mgl width"] / sets.loc["A", "mgl width"])
    noisy = _csv(page, "noisy", index_col=0)
    m = re.search(r"the median area of B is ([\d.]+)x that of A", md)
    assert _close(m.group(1), noisy.loc["B", "median area"] / noisy.loc["A", "median area"])


CLAIMS = {"lesson1": _claims_lesson1, "lesson2": _claims_lesson2, "lesson3": _claims_lesson3,
          "lesson4": _claims_lesson4, "lesson5": _claims_lesson5, "lesson6": _claims_lesson6}


@pytest.mark.parametrize("script", LESSONS, ids=[s.stem for s in LESSONS])
def test_lesson_runs_and_its_text_agrees_with_its_tables(script, tmp_path):
    """Run the lesson with BOUNDID_TEACH_FAST=1 into tmp_path: the page is self-contained (every
    <img> a decodable data: URI, no network URL, scripts allowed by hash only), opens with key
    points, has as many answers as exercises, frames of a stepper are >= 800 px wide and all of
    one size; then every claim of its text is compared with its own CSV tables."""
    page = run_lesson(script, tmp_path / script.stem, fast=True, notebook=False)  # as notebooks: test_notebooks.py
    parsed = _check_page(page)
    frames = [(src, width) for src, width, in_stepper in parsed.imgs if in_stepper]
    if parsed.steppers:
        assert len(frames) >= 3 and len({w for _, w in frames}) == 1 and int(frames[0][1]) >= 800
        assert len(list((page.parent / "figures").glob("*-[0-9][0-9].png"))) == len(frames)
    assert (page.parent / "summary.md").is_file()
    CLAIMS[script.stem.split("_")[0]](page)


def test_claim_checks_catch_a_contradiction(tmp_path):
    """The lesson-5 checker fails on a handout whose text names the wrong worst model (a table
    and a text written by hand here), so the claim tests above can fail."""
    (tmp_path / "tables").mkdir()
    pd.DataFrame({"model": ["a", "b"], "mean abs dev th1..th5 [%]": [1.0, 2.0],
                  "mean abs dev friction [%]": [3.0, 4.0]}).to_csv(tmp_path / "tables" / "models.csv", index=False)
    pd.DataFrame({"parameter": ["th1"], "a": [1.0], "b": [-2.0]}).to_csv(tmp_path / "tables" / "deviation.csv",
                                                                          index=False)
    text = ("Inertia and gravity terms (th1..th5): mean absolute deviation a 1 %, b 2 %; the {} model is the worst. "
            "Friction terms: a 3 %, b 4 %; the b model is the worst. The largest single deviation is th1 by the b "
            "model (-2 %).")
    (tmp_path / "summary.md").write_text(text.format("b"))
    _claims_lesson5(tmp_path / "index.html")
    (tmp_path / "summary.md").write_text(text.format("a"))
    with pytest.raises(AssertionError):
        _claims_lesson5(tmp_path / "index.html")


def test_lessons_are_percent_format_notebooks():
    """Each lesson has # %% cells; jupytext (if installed) reads it as a notebook with code and
    markdown cells."""
    for script in LESSONS:
        text = script.read_text(encoding="utf-8")
        assert text.count("# %%") >= 3 and "# %% [markdown]" in text
    jupytext = pytest.importorskip("jupytext")
    for script in LESSONS:
        nb = jupytext.read(script)
        kinds = {c.cell_type for c in nb.cells}
        assert kinds == {"code", "markdown"}


def _frame(k: int, size=(8.0, 4.0)) -> Figure:
    fig = Figure(figsize=size, layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, k])
    ax.set_title(f"frame {k}")
    return fig


def test_handout_stepper_key_points_and_instructor_key(tmp_path):
    """Handout.stepper embeds one PNG per frame (hidden but the first) and writes them as
    figures/<name>-NN.png; key points come first; the exercises' answers are only in the folded
    instructor key; booleans read yes/no on the page and stay True/False in the CSV; bad input
    raises InputError."""
    page = (Handout("t", "d", setup={"a": 1}).key_points(["one point", "two points"])
            .section("s", "text").stepper([_frame(k) for k in range(3)], ["a", "b", "c"], "frames", name="anim")
            .table(pd.DataFrame({"x": [1.5], "ok": [True]}, index=pd.Index(["r"], name="row")), "a table", name="t1")
            .exercises([("Question one?", "Answer one."), ("Question two?", "Answer two.")]))
    out = page.write(tmp_path / "index.html")
    text = out.read_text()
    pngs = sorted((tmp_path / "figures").glob("anim-*.png"))
    assert [p.name for p in pngs] == ["anim-01.png", "anim-02.png", "anim-03.png"]
    for p in pngs:
        assert base64.b64encode(p.read_bytes()).decode() in text
        assert Image.open(p).size == (800, 400)  # figsize x dpi 100, identical for every frame
    assert text.count(" hidden>") == 2 and text.index('class="keypoints"') < text.index("<h2>")
    key = re.search(r'<details class="key">(.*?)</details>', text, re.S).group(1)
    assert "Answer one." in key and text.count("Answer one.") == 1
    assert "<td class=\"words\">yes</td>" in text and "True" in (tmp_path / "tables" / "t1.csv").read_text()
    md = (tmp_path / "summary.md").read_text()
    assert "one point" in md and "**Answer.** Answer two." in md and "figures/anim-01.png" in md
    with pytest.raises(InputError, match="differ in size"):
        Handout("t").stepper([_frame(0), _frame(1, size=(6.0, 4.0))], ["a", "b"], "c", name="x")
    with pytest.raises(InputError, match="one label per frame"):
        Handout("t").stepper([_frame(0), _frame(1)], ["a"], "c", name="x")
    with pytest.raises(InputError):
        Handout("t").exercises([("q", "")])
    with pytest.raises(InputError):
        Handout("t").key_points("a string, not a list")


def test_handout_refuses_a_figure_with_a_clipped_legend():
    """Handout.figure runs the figure check: a legend anchored past the right edge is refused,
    the same legend placed outside the axes by the constrained layout is accepted."""
    fig = Figure(figsize=(4, 3))
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="a label long enough to leave the figure")
    ax.legend(loc="upper left", bbox_to_anchor=(0.8, 1.0))
    with pytest.raises(InputError, match="legend of axes 1 reaches outside the figure"):
        Handout("t").figure(fig, "clipped")
    fig = Figure(figsize=(6, 3), layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="a label long enough to leave the figure")
    fig.legend(loc="outside right upper")
    Handout("t").figure(fig, "fine")


def test_series_styles_are_distinct():
    """Every series style differs from every other in colour, marker and dash pattern."""
    styles = [series_style(i) for i in range(7)]
    for key in ("color", "marker", "linestyle"):
        assert len({str(s[key]) for s in styles}) == len(styles)
    with pytest.raises(InputError):
        series_style(7)


def test_runner_reports_a_failing_lesson_and_indexes_handouts(tmp_path):
    """Run as plain scripts: a lesson that raises gives StudyError with its traceback; run_lessons
    writes an index linking the handouts it produced (checked on a tiny lesson written here)."""
    d = tmp_path / "lessons"
    d.mkdir()
    (d / "lesson_bad.py").write_text("raise RuntimeError('boom')\n")
    with pytest.raises(StudyError, match="boom"):
        run_lesson(d / "lesson_bad.py", tmp_path / "bad", notebook=False)
    (d / "lesson_bad.py").unlink()
    (d / "lesson_ok.py").write_text(
        "from boundid.teaching import Handout, output_dir\n"
        "Handout('ok lesson').section('Exercises', 'none').write(output_dir('ok') / 'index.html')\n")
    pages = run_lessons(d, tmp_path / "out", fast=True, notebook=False)
    assert pages == [tmp_path / "out" / "lesson_ok" / "index.html"]
    assert "lesson_ok/index.html" in (tmp_path / "out" / "index.html").read_text()
    with pytest.raises(InputError):
        run_lessons(d, tmp_path / "out", only=["nothing"])
    with pytest.raises(InputError, match="holds no lesson"):
        run_lessons(tmp_path / "out", tmp_path / "out2")
