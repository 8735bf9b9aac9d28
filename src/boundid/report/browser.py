"""Open every report page in headless Chromium and fail on a broken image, a script error or a
network load (``make test-browser``).

Each page is copied to a temporary directory with a small checking script inserted at the top of
<head> (before the page's Content-Security-Policy, which therefore does not apply to it). The
script records error events (script errors and failed resource loads), CSP violations (any
attempted load of something that is not a data: URI), and after the load event every <img> that
did not decode (``!complete || naturalWidth == 0``) and every non-data resource fetched. It writes
the result as JSON into a ``<pre id="boundid-check">`` element; Chromium's ``--dump-dom`` prints the
DOM and this module reads the verdict from it.

Usage: ``python -m boundid.report.browser [reports_dir]`` (default ``reports``); exit status 0 if
every page passes, 1 if one fails, 2 if no browser or no page was found.
Browser: ``$BOUNDID_CHROMIUM`` or the first of chromium, chromium-browser, google-chrome on PATH
(Debian: ``apt-get install -y --no-install-recommends chromium``).
"""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

CHECK_SCRIPT = """<script>
(function () {
  var errors = [];
  window.addEventListener("error", function (e) {
    var t = e.target;
    errors.push(t && t !== window ? "failed to load " + t.tagName + " " + String(t.src || t.href || "").slice(0, 80)
                                  : "script error: " + e.message);
  }, true);
  document.addEventListener("securitypolicyviolation", function (e) {
    errors.push("blocked by CSP: " + String(e.blockedURI).slice(0, 80));
  });
  window.addEventListener("load", function () {
    var imgs = document.images, broken = [];
    for (var i = 0; i < imgs.length; i++) {
      if (!imgs[i].complete || imgs[i].naturalWidth === 0) broken.push(imgs[i].alt || ("image " + i));
    }
    var fetched = performance.getEntriesByType("resource").map(function (r) { return r.name; })
      .filter(function (n) { return n.slice(0, 5) !== "data:"; });
    var out = document.createElement("pre");
    out.id = "boundid-check";
    out.textContent = JSON.stringify({images: imgs.length, broken: broken, errors: errors, fetched: fetched});
    document.body.appendChild(out);
  });
})();
</script>"""

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-extensions",
    "--disable-dev-shm-usage",
    "--enable-logging=stderr",
    "--v=0",
    "--virtual-time-budget=10000",
    "--dump-dom",
)

_RESULT = re.compile(r'<pre id="boundid-check">(.*?)</pre>', re.S)


def find_browser() -> str | None:
    """The Chromium executable: $BOUNDID_CHROMIUM, else chromium / chromium-browser / google-chrome on PATH."""
    env = os.environ.get("BOUNDID_CHROMIUM")
    if env:
        return env
    return next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)


def check_page(page: Path, browser: str, timeout_s: float = 120.0) -> list[str]:
    """Problems found on one page (empty list: the page passed)."""
    source = page.read_text(encoding="utf-8")
    if "<head>" not in source:
        return ["no <head> element to attach the check to"]
    with tempfile.TemporaryDirectory(prefix="boundid-browser-") as tmp:
        copy = Path(tmp) / "page.html"
        copy.write_text(source.replace("<head>", "<head>\n" + CHECK_SCRIPT, 1), encoding="utf-8")
        cmd = [browser, *FLAGS, f"--user-data-dir={Path(tmp) / 'profile'}", copy.as_uri()]
        try:
            run = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False)
        except subprocess.TimeoutExpired:
            return [f"browser did not finish within {timeout_s:.0f} s"]
    match = _RESULT.search(run.stdout)
    if match is None:
        tail = " | ".join(run.stderr.strip().splitlines()[-3:])
        return [f"the check did not run (browser exit {run.returncode}): {tail}"]
    result = json.loads(html.unescape(match.group(1)))
    problems = [f"broken image: {alt}" for alt in result["broken"]]
    problems += result["errors"]
    problems += [f"network load: {url}" for url in result["fetched"]]
    problems += [line.strip() for line in run.stderr.splitlines() if "Uncaught" in line]
    return problems


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    root = Path(args[0] if args else "reports")
    browser = find_browser()
    if browser is None:
        print("no Chromium found: install it (Debian: apt-get install -y --no-install-recommends chromium) "
              "or set BOUNDID_CHROMIUM to the executable.", file=sys.stderr)
        return 2
    pages = sorted(root.glob("**/index.html"))
    if not pages:
        print(f"no index.html under {root}/: build the reports first (make report).", file=sys.stderr)
        return 2
    failed = 0
    for page in pages:
        problems = check_page(page, browser)
        failed += bool(problems)
        print(f"{'FAIL' if problems else 'ok  '} {page}")
        for p in problems:
            print(f"     - {p}")
    print(f"{len(pages) - failed} of {len(pages)} pages passed in {browser}.")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
