"""`make test-browser`: open every reports/**/index.html in headless Chromium and fail on a broken
image, a script error or a network load. Not collected by pytest (no test_ prefix).

Usage: python tests/browser_check.py [reports_dir]   (logic in boundid.report.browser)
"""

import sys

from boundid.report.browser import main

if __name__ == "__main__":
    sys.exit(main())
