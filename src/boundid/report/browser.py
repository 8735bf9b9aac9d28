"""Open every report page in headless Chromium at 1400 px, screenshot it, and fail on what a
reader would trip over (``make test-browser``).

Each page is copied to a temporary directory with a checking script inserted at the top of
<head> (before the page's Content-Security-Policy, which therefore does not apply to it). After
the load event the script looks at the laid-out page (the DOM at a 1400 px wide window) and
records:

* every <img> that did not decode (``!complete || naturalWidth == 0``), script errors, failed
  loads, CSP violations and any resource fetched that is not a data: URI (and, from the browser's
  console log, uncaught errors and Content-Security-Policy messages);
* every <table> wider than the box it sits in, unless that box scrolls sideways
  (``overflow-x: auto | scroll``) and shows a scroll cue: the CSS scroll shadows of
  :mod:`boundid.report.html` (a gradient background with ``background-attachment: local``) or a
  visible element marked ``data-scroll-cue``; and a page that scrolls sideways as a whole;
* for a frame stepper (the teaching handouts), that its frames show at >= 800 px, one at a time,
  that the next/previous buttons and the arrow keys move the frame counter, and that "play"
  advances it (virtual time: the timers run without waiting).

It writes the result as JSON into a ``<pre id="boundid-check">`` element; Chromium's ``--dump-dom``
prints the DOM and this module reads the verdict from it. Then it takes two screenshots of the
page itself: the first screen (1400 x 900, what a reader sees on opening it) and the whole page
(up to FULL_PAGE_MAX_PX tall), into ``--shots`` (default ``build/screenshots``). Figures are
checked where they are made: :func:`boundid.report.figure_check.figure_problems`.

Usage: ``python -m boundid.report.browser [reports_dir] [--shots DIR]`` (default ``reports``);
exit status 0 if every page passes, 1 if one fails, 2 if no browser or no page was found.
Browser: ``$BOUNDID_CHROMIUM`` or the first of chromium, chromium-browser, google-chrome on PATH
(Debian: ``apt-get install -y --no-install-recommends chromium``).
"""

from __future__ import annotations

import argparse
import html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from boundid.report.html import DOCS_DIR  # the documentation site's folder under the reports folder

WIDTH, FIRST_SCREEN = 1400, 900  # px: the window a reader opens the page in
FULL_PAGE_MAX_PX = 16000  # Chromium's screenshots stop being reliable beyond ~16k px
MIN_FRAME_PX = 800  # a stepper frame must show at least this wide

CHECK_SCRIPT = """<script>
(function () {
  var errors = [];
  window.addEventListener("error", function (e) {
    var t = e.target;
    errors.push(t && t !== window ? "failed to load " + t.tagName + " " + String(t.src || t.href || "").slice(0, 80)
                                  : "script error: " + e.message);
  }, true);
  document.addEventListener("securitypolicyviolation", function (e) {
    errors.push("blocked by CSP: " + String(e.blockedURI).slice(0, 80) + " (" + e.violatedDirective + ")");
  });
  function label(el) {
    var fig = el.closest("figure"), cap = fig ? fig.querySelector("figcaption") : null;
    return (cap ? cap.textContent : el.textContent).replace(/\\s+/g, " ").trim().slice(0, 70);
  }
  function scrolls(el) {
    var o = getComputedStyle(el).overflowX;
    return o === "auto" || o === "scroll";
  }
  function visible(el) {
    var r = el.getBoundingClientRect(), s = getComputedStyle(el);
    return r.width > 0 && r.height > 0 && s.visibility !== "hidden" && s.display !== "none" && Number(s.opacity) > 0;
  }
  function cue(box) {
    var s = getComputedStyle(box);
    if (s.backgroundImage.indexOf("gradient") >= 0 && s.backgroundAttachment.indexOf("local") >= 0) { return true; }
    var hints = (box.parentElement || box).querySelectorAll("[data-scroll-cue]");
    for (var i = 0; i < hints.length; i++) { if (visible(hints[i])) { return true; } }
    return false;
  }
  function tables() {
    var out = [], ts = document.querySelectorAll("table");
    for (var i = 0; i < ts.length; i++) {
      var t = ts[i], box = t.parentElement, w = t.getBoundingClientRect().width;
      if (w <= box.clientWidth + 1) { continue; }
      var what = "table " + (i + 1) + " ('" + label(t) + "') is " + Math.round(w) + " px wide in a " +
                 box.clientWidth + " px box";
      if (!scrolls(box)) { out.push(what + " that does not scroll"); }
      else if (!cue(box)) { out.push(what + " that scrolls without a visible scroll cue"); }
    }
    var doc = document.documentElement;
    if (doc.scrollWidth > window.innerWidth + 1) {
      out.push("the page scrolls sideways (" + doc.scrollWidth + " px in a " + window.innerWidth + " px window)");
    }
    return out;
  }
  function steppers() {
    var out = [], ss = document.querySelectorAll(".stepper");
    function frame(s) { return s.getAttribute("data-frame"); }
    function key(k) { document.body.dispatchEvent(new KeyboardEvent("keydown", {key: k, bubbles: true})); }
    for (var i = 0; i < ss.length; i++) {
      var s = ss[i], name = "stepper " + (i + 1) + " ('" + label(s) + "')";
      var imgs = s.querySelectorAll(".stepper-frames img"), shown = 0, w = 0;
      for (var k = 0; k < imgs.length; k++) {
        if (visible(imgs[k])) { shown += 1; w = imgs[k].getBoundingClientRect().width; }
      }
      if (imgs.length < 2) { out.push(name + " has " + imgs.length + " frames"); continue; }
      if (shown !== 1) { out.push(name + " shows " + shown + " frames at once"); }
      if (w < MIN) { out.push(name + ": its frame shows " + Math.round(w) + " px wide, under " + MIN + " px"); }
      var seen = [frame(s)];
      s.querySelector("[data-step=next]").click(); seen.push(frame(s));
      if (i === 0) { key("ArrowRight"); seen.push(frame(s)); key("ArrowLeft"); seen.push(frame(s)); }
      s.querySelector("[data-step=prev]").click(); seen.push(frame(s));
      var want = i === 0 ? "1,2,3,2,1" : "1,2,1";
      if (seen.join(",") !== want) {
        out.push(name + " does not step: frame counter went " + seen.join(",") + ", expected " + want);
      }
    }
    return out;
  }
  function play(then) {
    /* the first stepper's play button: after 2.5 frame delays the counter must have moved 2 frames */
    var s = document.querySelector(".stepper"), b = s && s.querySelector("[data-step=play]");
    if (!b) { then([]); return; }
    var delay = Number(s.getAttribute("data-delay")) || 900;
    b.click();
    setTimeout(function () {
      var f = s.getAttribute("data-frame");
      b.click();
      then(f === "3" ? [] : ["stepper 1 does not play: after 2.5 frame delays it shows frame " + f + ", expected 3"]);
    }, 2.5 * delay);
  }
  var MIN = MIN_FRAME_PX;
  window.addEventListener("load", function () {
    var imgs = document.images, broken = [];
    for (var i = 0; i < imgs.length; i++) {
      if (!imgs[i].complete || imgs[i].naturalWidth === 0) broken.push(imgs[i].alt || ("image " + i));
    }
    var fetched = performance.getEntriesByType("resource").map(function (r) { return r.name; })
      .filter(function (n) { return n.slice(0, 5) !== "data:"; });
    var result = {images: imgs.length, broken: broken, errors: errors, fetched: fetched, layout: tables(),
                  steppers: steppers(), height: document.documentElement.scrollHeight};
    play(function (problems) {
      result.steppers = result.steppers.concat(problems);
      var out = document.createElement("pre");
      out.id = "boundid-check";
      out.textContent = JSON.stringify(result);
      document.body.appendChild(out);
    });
  });
})();
</script>""".replace("MIN_FRAME_PX", str(MIN_FRAME_PX))

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--hide-scrollbars",
    "--disable-quic",
    "--disable-extensions",
    "--disable-dev-shm-usage",
    "--enable-logging=stderr",
    "--v=0",
)

_RESULT = re.compile(r'<pre id="boundid-check">(.*?)</pre>', re.S)


def find_browser() -> str | None:
    """The Chromium executable: $BOUNDID_CHROMIUM, else chromium / chromium-browser / google-chrome on PATH."""
    env = os.environ.get("BOUNDID_CHROMIUM")
    if env:
        return env
    return next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)


def _run(browser: str, profile: Path, args: list[str], timeout_s: float) -> subprocess.CompletedProcess | None:
    cmd = [browser, *FLAGS, f"--user-data-dir={profile}", *args]
    try:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        return None


def check_page(page: Path, browser: str, shots: Path | None = None, name: str = "page",
               timeout_s: float = 120.0) -> list[str]:
    """Problems found on one page (empty list: the page passed); with ``shots``, also write
    ``<shots>/<name>.png`` (first screen) and ``<name>-full.png`` (whole page)."""
    source = page.read_text(encoding="utf-8")
    if "<head>" not in source:
        return ["no <head> element to attach the check to"]
    with tempfile.TemporaryDirectory(prefix="boundid-browser-") as tmp:
        copy = Path(tmp) / "page.html"
        copy.write_text(source.replace("<head>", "<head>\n" + CHECK_SCRIPT, 1), encoding="utf-8")
        run = _run(browser, Path(tmp) / "profile", [f"--window-size={WIDTH},{FIRST_SCREEN}",
                                                    "--virtual-time-budget=10000", "--dump-dom", copy.as_uri()],
                   timeout_s)
        if run is None:
            return [f"browser did not finish within {timeout_s:.0f} s"]
        match = _RESULT.search(run.stdout)
        if match is None:
            tail = " | ".join(run.stderr.strip().splitlines()[-3:])
            return [f"the check did not run (browser exit {run.returncode}): {tail}"]
        result = json.loads(html.unescape(match.group(1)))
        problems = [f"broken image: {alt}" for alt in result["broken"]]
        problems += result["errors"] + result["layout"] + result["steppers"]
        problems += [f"network load: {url}" for url in result["fetched"]]
        console = re.findall(r':CONSOLE[^\]]*\] "(.*?)", source', run.stderr)
        problems += [f"console: {c[:200]}" for c in console if "Uncaught" in c or "Content Security Policy" in c]
        if shots is not None:
            shots.mkdir(parents=True, exist_ok=True)
            height = min(int(result["height"]), FULL_PAGE_MAX_PX)
            for suffix, size in (("", f"{WIDTH},{FIRST_SCREEN}"), ("-full", f"{WIDTH},{height}")):
                out = shots / f"{name}{suffix}.png"
                shot = _run(browser, Path(tmp) / "profile", [f"--window-size={size}", f"--screenshot={out}",
                                                             page.resolve().as_uri()], timeout_s)
                if shot is None or not out.is_file():
                    problems.append(f"no screenshot {out.name} (browser exit {getattr(shot, 'returncode', 'timeout')})")
    return problems


def shot_name(page: Path, root: Path) -> str:
    """File stem of a page's screenshots: reports/teaching/lesson1/index.html -> teaching__lesson1."""
    return "__".join(page.parent.relative_to(root).parts) or "index"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m boundid.report.browser", description=__doc__.split("\n\n")[0])
    ap.add_argument("reports", nargs="?", default="reports", help="folder searched for **/index.html")
    ap.add_argument("--shots", default="build/screenshots", help="folder for the screenshots ('' for none)")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    root = Path(args.reports)
    browser = find_browser()
    if browser is None:
        print("no Chromium found: install it (Debian: apt-get install -y --no-install-recommends chromium) "
              "or set BOUNDID_CHROMIUM to the executable.", file=sys.stderr)
        return 2
    # the report pages, each self-contained; the documentation site (make docs: Sphinx, its own _static/
    # folder and search) is a site of its own, not checked page by page here
    pages = sorted(p for p in root.glob("**/index.html") if p.relative_to(root).parts[0] != DOCS_DIR)
    if not pages:
        print(f"no index.html under {root}/: build the reports first (make report).", file=sys.stderr)
        return 2
    shots = Path(args.shots) if args.shots else None
    failed = 0
    for page in pages:
        problems = check_page(page, browser, shots, shot_name(page, root))
        failed += bool(problems)
        print(f"{'FAIL' if problems else 'ok  '} {page}")
        for p in problems:
            print(f"     - {p}")
    where = f"; screenshots at {WIDTH} px in {shots}/" if shots else ""
    print(f"{len(pages) - failed} of {len(pages)} pages passed in {browser}{where}.")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
