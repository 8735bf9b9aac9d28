"""The teaching kit: lessons in ``studies/teaching/lesson*.py`` and their HTML handouts.

A lesson is a percent-format Python script (``# %%`` cells): it runs with plain ``python`` and
opens as a notebook through jupytext. Each builds a :class:`Handout` (a
:class:`boundid.report.Page` with a key-points box, frame steppers and an instructor key) and
writes it to :func:`output_dir`. Two environment variables steer a lesson:

* ``BOUNDID_TEACH_OUT``: the folder its handout goes to (default ``reports/teaching/<lesson>``);
* ``BOUNDID_TEACH_FAST=1``: smaller settings (fewer samples and frames), for the tests.

:func:`run_lessons` runs every lesson in a subprocess (a clean interpreter each, as a student
would) and writes ``<out>/index.html`` linking the handouts. :func:`lessons_dir` finds the
lessons when ``boundid teach`` is run from any folder.
"""

from __future__ import annotations

import base64
import hashlib
import html
import io
import os
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import pandas as pd
from matplotlib.figure import Figure
from PIL import Image

from boundid.errors import InputError, StudyError
from boundid.report.figure_check import figure_problems
from boundid.report.html import Page, Table, paragraphs, slug, write_index
from boundid.report.output import check_out_dir, replace_folder
from boundid.resources import find_folder

OUT_ENV, FAST_ENV = "BOUNDID_TEACH_OUT", "BOUNDID_TEACH_FAST"
DEFAULT_OUT = Path("reports/teaching")
LESSONS_SUBDIR = Path("studies/teaching")

# Distinct series in a lesson figure that are not estimators (seeds, shuffles, models): the
# Okabe-Ito colour-blind-safe colours (yellow left out: unreadable on white), each with its own
# marker and dash pattern, so series stay apart in grey print too. Estimators keep
# boundid.report.color_for.
SERIES_STYLES: tuple[dict, ...] = (
    {"color": "#0072B2", "marker": "o", "linestyle": "-"},
    {"color": "#D55E00", "marker": "s", "linestyle": "--"},
    {"color": "#009E73", "marker": "^", "linestyle": "-."},
    {"color": "#CC79A7", "marker": "D", "linestyle": ":"},
    {"color": "#E69F00", "marker": "v", "linestyle": (0, (5, 1.5, 1, 1.5, 1, 1.5))},
    {"color": "#56B4E9", "marker": "P", "linestyle": (0, (8, 2))},
    {"color": "#000000", "marker": "X", "linestyle": (0, (1, 1))},
)


def series_style(i: int) -> dict:
    """Colour, marker and line style of the ``i``-th series of a lesson figure (matplotlib kwargs)."""
    if not 0 <= i < len(SERIES_STYLES):
        raise InputError(f"a lesson figure draws at most {len(SERIES_STYLES)} distinguishable series; got index {i}.")
    return dict(SERIES_STYLES[i])


def fast_mode() -> bool:
    """True when ``BOUNDID_TEACH_FAST=1`` (lessons then use smaller settings)."""
    return os.environ.get(FAST_ENV, "0") == "1"


def output_dir(lesson: str) -> Path:
    """Folder of a lesson's handout: ``$BOUNDID_TEACH_OUT`` or ``reports/teaching/<lesson>``."""
    return Path(os.environ.get(OUT_ENV) or DEFAULT_OUT / lesson)


def fmt(x: float, digits: int = 3) -> str:
    """A number for a sentence of a handout: ``digits`` significant digits, no trailing zeros."""
    return f"{x:.{digits}g}"


# --------------------------------------------------------------------------------- page blocks
@dataclass
class _KeyPoints:
    items: list[str]

    def html(self) -> str:
        lis = "".join(f"<li>{html.escape(' '.join(t.split()))}</li>" for t in self.items)
        return f'<div class="keypoints"><p class="kp-head">What this run shows</p><ul>{lis}</ul></div>'

    def markdown(self) -> str:
        return "**What this run shows**\n\n" + "\n".join(f"- {' '.join(t.split())}" for t in self.items)


@dataclass
class _Setup:
    items: dict

    def html(self) -> str:
        rows = "".join(f"<dt>{html.escape(str(k))}</dt><dd>{html.escape(str(v))}</dd>" for k, v in self.items.items())
        return (f'<details class="setup-box"><summary>Set-up of this run</summary><dl class="setup">{rows}</dl>'
                "</details>")

    def markdown(self) -> str:
        return "\n".join(f"- **{k}**: {v}" for k, v in self.items.items())


@dataclass
class _Exercises:
    items: list[tuple[str, str]]

    def html(self) -> str:
        lis = "".join(f"<li>{paragraphs(q)}</li>" for q, _ in self.items)
        return f'<ol class="exercises">{lis}</ol>'

    def markdown(self) -> str:
        return "\n\n".join(f"{k}. {' '.join(q.split())}" for k, (q, _) in enumerate(self.items, 1))


@dataclass
class _Key:
    items: list[tuple[str, str]]

    def html(self) -> str:
        lis = "".join(f'<li><div class="q">{paragraphs(q)}</div><div class="a"><b>Answer.</b>{paragraphs(a)}</div>'
                      "</li>" for q, a in self.items)
        return ('<details class="key"><summary>For instructors: the answers, computed by this run '
                f'(click to open)</summary><ol>{lis}</ol></details>')

    def markdown(self) -> str:
        return "\n\n".join(f"{k}. {' '.join(q.split())}\n\n   **Answer.** {' '.join(a.split())}"
                           for k, (q, a) in enumerate(self.items, 1))


# The stepper's script, the only one a handout runs (the page's CSP allows it by its SHA-256).
# Each <figure class="stepper"> holds its frames as <img> elements, all but one hidden; buttons,
# a slider and the keys (left/right arrows anywhere on the page; Home, End and space when the
# stepper has the focus) choose the frame shown.
_STEPPER_JS = """
(function () {
  "use strict";
  var all = [], current = null;
  function Stepper(root) {
    var frames = root.querySelectorAll(".stepper-frames img");
    var count = root.querySelector(".stepper-count"), label = root.querySelector(".stepper-label");
    var range = root.querySelector("input[type=range]"), play = root.querySelector("[data-step=play]");
    var delay = Number(root.getAttribute("data-delay")) || 900, i = 0, timer = null;
    function show(k) {
      k = Math.max(0, Math.min(frames.length - 1, k));
      frames[i].hidden = true;
      frames[k].hidden = false;
      i = k;
      count.textContent = "frame " + (k + 1) + " of " + frames.length;
      label.textContent = frames[k].getAttribute("data-label");
      range.value = String(k + 1);
      root.setAttribute("data-frame", String(k + 1));
    }
    function stop() {
      if (timer !== null) { clearInterval(timer); timer = null; }
      play.textContent = "\\u25B6 play";
    }
    function start() {
      if (i === frames.length - 1) { show(0); }
      timer = setInterval(function () { if (i === frames.length - 1) { stop(); } else { show(i + 1); } }, delay);
      play.textContent = "\\u275A\\u275A pause";
    }
    this.act = function (a) {
      current = this;
      if (a === "play") { if (timer === null) { start(); } else { stop(); } return; }
      stop();
      show(a === "first" ? 0 : a === "last" ? frames.length - 1 : i + (a === "next" ? 1 : -1));
    };
    var self = this;
    root.addEventListener("click", function (e) {
      var b = e.target.closest("[data-step]");
      if (b) { self.act(b.getAttribute("data-step")); }
    });
    range.addEventListener("input", function () { current = self; stop(); show(Number(range.value) - 1); });
    root.stepper = this;
    show(0);
  }
  function init() {
    var roots = document.querySelectorAll(".stepper");
    for (var k = 0; k < roots.length; k++) { all.push(new Stepper(roots[k])); }
  }
  document.addEventListener("keydown", function (e) {
    if (e.altKey || e.ctrlKey || e.metaKey || !all.length) { return; }
    var t = e.target, inside = t && t.closest ? t.closest(".stepper") : null;
    if (t && t.matches && t.matches("input, textarea, select")) { return; }
    var s = inside ? inside.stepper : current || all[0];
    var a = {ArrowLeft: "prev", ArrowRight: "next"}[e.key];
    if (!a && inside) { a = {Home: "first", End: "last", " ": "play"}[e.key]; }
    if (a) { e.preventDefault(); s.act(a); }
  });
  if (document.readyState === "loading") { document.addEventListener("DOMContentLoaded", init); } else { init(); }
})();
"""
_STEPPER_HASH = base64.b64encode(hashlib.sha256(_STEPPER_JS.encode("utf-8")).digest()).decode("ascii")

_HANDOUT_CSS = """
.keypoints { border-left: 4px solid var(--accent); background: #eef6fb; padding: .6rem 1rem .5rem;
             margin: 1rem 0; border-radius: 0 6px 6px 0; max-width: 80ch; }
.keypoints .kp-head { font-weight: 700; margin: 0 0 .2rem; }
.keypoints ul { margin: .2rem 0; padding-left: 1.2rem; } .keypoints li { margin: .2rem 0; }
details.setup-box > summary, details.key > summary { cursor: pointer; font-weight: 600; color: var(--muted); }
details.key { border: 1px dashed var(--muted); border-radius: 6px; padding: .5rem 1rem; background: #fffdf5; }
details.key[open] > summary { margin-bottom: .5rem; }
details.key li { margin: .8rem 0; } details.key .q { color: var(--muted); }
details.key .a p:first-of-type { display: inline; }
ol.exercises li { margin: .6rem 0; }
figure.stepper { margin: 1.2rem 0; }
.stepper-bar { display: flex; flex-wrap: wrap; align-items: center; gap: .5rem; margin: 0 0 .4rem; }
.stepper-bar button { font: inherit; font-size: .95rem; padding: .3rem .8rem; border: 1px solid var(--line);
                      border-radius: 5px; background: var(--bg-alt); cursor: pointer; }
.stepper-bar button:hover { border-color: var(--accent); }
.stepper-bar input[type=range] { flex: 1 1 12rem; }
.stepper-count { font-variant-numeric: tabular-nums; min-width: 8.5rem; }
.stepper-label { font-weight: 600; margin: .2rem 0 .4rem; min-height: 1.5em; }
.stepper-frames img { display: block; max-width: 100%; height: auto; border: 1px solid var(--line);
                      border-radius: 4px; }
.stepper-frames img[hidden] { display: none; }
figure.stepper:focus { outline: 2px solid var(--accent); outline-offset: 4px; }
"""


@dataclass
class _Stepper:
    frames: list[bytes]  # PNG, all of one size
    labels: list[str]
    caption: str
    name: str
    size: tuple[int, int]
    delay_ms: int
    first_on_page: bool

    def html(self) -> str:
        n, (w, h) = len(self.frames), self.size
        imgs = "".join(
            f'<img src="data:image/png;base64,{base64.b64encode(png).decode("ascii")}" width="{w}" height="{h}" '
            f'alt="{html.escape(lab)}" data-label="{html.escape(lab)}"{" hidden" if k else ""}>'
            for k, (png, lab) in enumerate(zip(self.frames, self.labels, strict=True)))
        cap = html.escape(self.caption)
        script = f"<script>{_STEPPER_JS}</script>" if self.first_on_page else ""
        return (f'<figure class="stepper" id="stepper-{self.name}" tabindex="0" data-delay="{self.delay_ms}" '
                f'aria-label="{cap}"><div class="stepper-bar">'
                '<button type="button" data-step="first" title="first frame (Home)">first</button>'
                '<button type="button" data-step="prev" title="previous frame (left arrow)">&#x25C0; previous</button>'
                '<button type="button" data-step="play" title="play / pause (space)">&#x25B6; play</button>'
                '<button type="button" data-step="next" title="next frame (right arrow)">next &#x25B6;</button>'
                f'<input type="range" min="1" max="{n}" value="1" aria-label="frame">'
                f'<output class="stepper-count">frame 1 of {n}</output></div>'
                f'<p class="stepper-label">{html.escape(self.labels[0])}</p>'
                f'<div class="stepper-frames">{imgs}</div>'
                f'<figcaption><b>Frames.</b> {cap} Keys: left and right arrows step through the frames; '
                f'click the frames first for space (play/pause), Home and End.<span class="files">'
                f'<a href="figures/{self.name}-01.png">PNG frames</a></span></figcaption></figure>{script}')

    def markdown(self) -> str:
        return (f"**Frames.** {self.caption} ({len(self.frames)} frames: "
                f"[first](figures/{self.name}-01.png) ... [last](figures/{self.name}-{len(self.frames):02d}.png))")

    def files(self) -> dict[str, bytes]:
        return {f"{self.name}-{k:02d}.png": png for k, png in enumerate(self.frames, 1)}


_BLOCKS = (_KeyPoints, _Setup, _Exercises, _Key, _Stepper)


def _png(fig: Figure, dpi: int, colors: int) -> tuple[bytes, tuple[int, int]]:
    """A figure as a palette PNG of at most ``colors`` colours (small enough to embed many frames)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    img = Image.open(buf).convert("RGB").quantize(colors=colors, method=Image.Quantize.MEDIANCUT)
    out = io.BytesIO()
    img.save(out, format="PNG", optimize=True)
    return out.getvalue(), img.size


class Handout(Page):
    """A :class:`Page` for a lesson. Beyond Page's sections, texts, tables and figures:

    * :meth:`key_points`: the sentences a reader must take away, in a box on the first screen,
      written by the lesson from its own numbers;
    * :meth:`stepper`: an animation as frames with previous/next/play buttons, a slider, a frame
      counter and arrow keys (a few lines of inline JavaScript, allowed by hash in the page's
      Content-Security-Policy; the page stays self-contained and works from file://);
    * :meth:`exercises`: questions, and the answers the lesson computed in a folded
      "Instructor key" section;
    * every figure and frame is checked by :func:`boundid.report.figure_check.figure_problems`
      (nothing cut off, no overlapping tick labels) before it goes in: InputError otherwise.

    The set-up (``setup``) is shown folded under the key points instead of above the contents.
    """

    css = Page.css + _HANDOUT_CSS
    csp = f"{Page.csp}; script-src 'sha256-{_STEPPER_HASH}'"

    def __init__(self, title: str, description: str = "", *, setup: Mapping[str, object] | None = None, **kwargs):
        kwargs.setdefault("home", "../../index.html")  # a handout lives at reports/teaching/<lesson>/
        kwargs.setdefault("trail", [("teaching kit", "../index.html")])
        super().__init__(title, description, **kwargs)
        self._key_points: _KeyPoints | None = None
        if setup:
            self._sections[0].blocks.append(_Setup(dict(setup)))

    def key_points(self, items: Sequence[str]) -> Handout:
        """The lesson's message, a few sentences (computed from the run's numbers), in a box at the top."""
        if isinstance(items, str) or not items or not all(isinstance(t, str) and t.strip() for t in items):
            raise InputError("Handout.key_points takes a non-empty list of sentences.")
        if self._key_points is not None:
            raise InputError("Handout.key_points was already given; pass every sentence in one call.")
        self._key_points = _KeyPoints(list(items))
        self._sections[0].blocks.insert(0, self._key_points)
        return self

    def figure(self, fig: Figure, caption: str, *, name: str | None = None) -> Handout:
        _check_figure(fig, name or caption)
        return super().figure(fig, caption, name=name)

    def stepper(self, frames: Sequence[Figure], labels: Sequence[str], caption: str, *, name: str,
                dpi: int = 100, delay_ms: int = 900, colors: int = 96) -> Handout:
        """An animation in the current section: one matplotlib figure per frame (all of one size,
        drawn with fixed axes by the caller), ``labels`` one line of text per frame (shown above
        it and as its alt text). Frames are embedded as palette PNGs and written as
        ``figures/<name>-NN.png``. Show it at >= 800 px: e.g. figsize (10, 4.8) at dpi 100."""
        if len(frames) < 2 or len(frames) != len(labels):
            raise InputError(f"Handout.stepper needs >= 2 frames and one label per frame; got {len(frames)} frames "
                             f"and {len(labels)} labels.")
        pngs, sizes = [], set()
        for k, fig in enumerate(frames):
            if not isinstance(fig, Figure):
                raise InputError(f"Handout.stepper: frame {k + 1} is a {type(fig).__name__}, not a matplotlib Figure.")
            _check_figure(fig, f"{name}, frame {k + 1}")
            png, size = _png(fig, dpi, colors)
            pngs.append(png)
            sizes.add(size)
        if len(sizes) != 1:
            raise InputError(f"Handout.stepper: the frames of {name!r} differ in size {sorted(sizes)}; give every "
                             "frame the same figsize (and no tight bounding box), so the axes stay fixed.")
        first = not any(isinstance(b, _Stepper) for s in self._sections for b in s.blocks)
        self._sections[-1].blocks.append(_Stepper(pngs, [str(t) for t in labels], caption,
                                                  slug(name, self._names), sizes.pop(), delay_ms, first))
        return self

    def exercises(self, items: Sequence[tuple[str, str]]) -> Handout:
        """Sections "Exercises" (the questions) and "Instructor key" (each question with the answer
        the lesson computed, folded). ``items``: (question, answer) pairs of plain text."""
        if not items or not all(isinstance(q, str) and isinstance(a, str) and q.strip() and a.strip()
                                for q, a in items):
            raise InputError("Handout.exercises takes a non-empty list of (question, answer) text pairs.")
        self.section("Exercises")
        self._sections[-1].blocks.append(_Exercises(list(items)))
        self.section("Instructor key")
        self._sections[-1].blocks.append(_Key(list(items)))
        return self

    # ------------------------------------------------------------------------------ output
    def _block_html(self, block) -> str:
        if isinstance(block, _BLOCKS):
            return block.html()
        if isinstance(block, Table):  # yes/no on the page; the CSV keeps True/False
            df = block.df.copy()
            for col in df.columns[[pd.api.types.is_bool_dtype(t) for t in df.dtypes]]:
                df[col] = df[col].map({True: "yes", False: "no"})
            block = replace(block, df=df)
        return super()._block_html(block)

    def to_markdown(self) -> str:
        saved = [s.blocks for s in self._sections]
        for s in self._sections:  # the handout's own blocks become Markdown text for Page's rendering
            s.blocks = [b.markdown() if isinstance(b, _BLOCKS) else b for b in s.blocks]
        try:
            return super().to_markdown()
        finally:
            for s, blocks in zip(self._sections, saved, strict=True):
                s.blocks = blocks

    def write(self, path: str | Path) -> Path:
        out = super().write(path)
        steppers = [b for s in self._sections for b in s.blocks if isinstance(b, _Stepper)]
        if steppers:
            (out.parent / "figures").mkdir(exist_ok=True)
        for st in steppers:
            for name, png in st.files().items():
                (out.parent / "figures" / name).write_bytes(png)
        return out


def _check_figure(fig: Figure, what: str) -> None:
    problems = figure_problems(fig)
    if problems:
        raise InputError(f"figure {what!r} cuts off or overlaps what a reader must read: " + "; ".join(problems)
                         + ". Put legends outside the axes with fig.legend(loc='outside ...') and a constrained "
                           "layout, and use fewer ticks or a larger figure.")


# --------------------------------------------------------------------------------- running
def lessons_dir(directory: str | Path | None = None) -> Path:
    """The folder of the lesson scripts: ``directory`` if given, else ``studies/teaching`` of the
    current folder or of the boundid checkout the package runs from (see
    :func:`boundid.resources.find_folder`)."""
    return find_folder(LESSONS_SUBDIR, "lesson*.py", directory, what="lesson scripts", option="--lessons")


def lessons(directory: str | Path | None = None) -> list[Path]:
    """The lesson scripts ``lesson*.py`` of ``directory`` (default :func:`lessons_dir`), in name order."""
    return sorted(lessons_dir(directory).glob("lesson*.py"))


def run_lesson(script: str | Path, out_dir: str | Path, fast: bool = False, timeout: float = 600.0) -> Path:
    """Run one lesson script with ``python`` (a fresh interpreter); returns its handout page.

    The handout is written into a fresh folder that replaces ``out_dir`` as a whole once the lesson
    succeeded (:func:`boundid.report.output.replace_folder`: no file of an earlier run is left
    behind, and a failed run leaves the previous handout as it was). Raises :class:`StudyError`
    with the end of the script's stderr when it fails or writes no page.
    """
    script, out_dir = Path(script), Path(out_dir)
    with replace_folder(out_dir) as tmp:
        env = {**os.environ, OUT_ENV: str(tmp), FAST_ENV: "1" if fast else "0", "MPLBACKEND": "Agg"}
        res = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True,
                             timeout=timeout)
        if res.returncode != 0 or not (tmp / "index.html").is_file():
            raise StudyError(f"lesson {script.name} failed (exit {res.returncode}):\n{res.stderr[-3000:]}")
    return out_dir / "index.html"


def run_lessons(directory: str | Path | None = None, out: str | Path = DEFAULT_OUT, fast: bool = False,
                only: list[str] | None = None) -> list[Path]:
    """Run the lessons (all, or those whose file stem contains one of ``only``), writing each
    handout to ``<out>/<stem>/index.html`` and ``<out>/index.html`` linking them."""
    found = lessons(directory)
    scripts = [s for s in found if not only or any(o in s.stem for o in only)]
    if not scripts:
        raise InputError(f"no lesson matches {only}; lessons: {[s.stem for s in found]}.")
    check_out_dir(out, tuple(s.stem for s in scripts))
    pages = [run_lesson(s, Path(out) / s.stem, fast) for s in scripts]
    write_index(out, None, title="boundid teaching kit",
                description="Handouts of the boundid lessons: feasible sets, OBE, the factorized form, "
                            "statistics versus bounds, and the direct-drive arm's regression models. Each handout "
                            "is one self-contained page (it works offline) with exercises and an instructor key.")
    return pages
