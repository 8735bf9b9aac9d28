"""`make test-browser`: open every reports/**/index.html in headless Chromium at 1400 px, screenshot
it, and fail on a broken image, a script error, a network load, a table wider than its box without
a scroll cue, or a frame stepper that does not step. Not collected by pytest (no test_ prefix).

Usage: python tests/browser_check.py [reports_dir] [--shots DIR]   (logic in boundid.report.browser)
"""

import sys

from boundid.report.browser import main

if __name__ == "__main__":
    sys.exit(main())
