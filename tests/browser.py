"""Open an HTML file in headless Chromium (Debian's chromium and chromium-driver, through
selenium) and look at it as a person would: which images decoded, what a table says, what the
console said, and a full-page screenshot.

Used by the report tests; also a command that makes the docs' screenshot of a report:

    python3 tests/browser.py report.html screenshot.png [--width 1280] [--max-height 0] [--scale 1]
"""
from __future__ import annotations

import base64
import shutil
import sys
import tempfile
from pathlib import Path

CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromium-browser")
CHROMEDRIVER = ("/usr/bin/chromedriver",)
# A closed network and a throwaway profile: nothing to fetch, nothing to sync, no GPU.
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-dev-shm-usage",
         "--hide-scrollbars")


def missing():
    """Why the browser cannot run here (None when it can)."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install -e '.[test]')"
    if not any(Path(p).exists() for p in CHROMIUM):
        return "Chromium is not installed (Debian package chromium)"
    if not any(Path(p).exists() for p in CHROMEDRIVER):
        return "ChromeDriver is not installed (Debian package chromium-driver)"
    return None


class Browser:
    """A headless Chromium with a fresh profile; use as a context manager."""

    def __init__(self, width=1280, height=900):
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service

        self.profile = tempfile.mkdtemp(prefix="lidar-sig-chromium-")
        options = webdriver.ChromeOptions()
        options.binary_location = next(p for p in CHROMIUM if Path(p).exists())
        for flag in FLAGS:
            options.add_argument(flag)
        options.add_argument(f"--user-data-dir={self.profile}")
        options.add_argument(f"--window-size={width},{height}")
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        # the driver is given, so selenium never tries to download one
        service = Service(executable_path=next(p for p in CHROMEDRIVER if Path(p).exists()))
        self.driver = webdriver.Chrome(options=options, service=service)
        self.width = width

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.driver.quit()
        shutil.rmtree(self.profile, ignore_errors=True)

    def open(self, path):
        self.driver.get(Path(path).resolve().as_uri())
        # wait until every image has finished loading, decoded or not
        self.driver.execute_async_script(
            "const done = arguments[arguments.length - 1];"
            "Promise.all([...document.images].map(i => i.decode().catch(() => null))).then(() => done());")

    def images(self):
        """[(alt, naturalWidth, naturalHeight)] of every image of the page."""
        return self.driver.execute_script(
            "return [...document.images].map(i => [i.alt, i.naturalWidth, i.naturalHeight]);")

    def table(self, selector):
        """Rows of the first table matching ``selector``, as lists of cell texts."""
        return self.driver.execute_script(
            "const t = document.querySelector(arguments[0]); if (!t) return null;"
            "return [...t.querySelectorAll('tbody tr')].map(r => [...r.cells].map(c => c.innerText.trim()));",
            selector)

    def console(self):
        """The console's entries since the page opened: [(level, message)]."""
        return [(e["level"], e["message"]) for e in self.driver.get_log("browser")]

    def screenshot(self, path, *, max_height=0, scale=1.0):
        """A PNG of the whole page (or its top ``max_height`` CSS px) at the window's width,
        ``scale`` device pixels per CSS pixel."""
        height = self.driver.execute_script("return document.documentElement.scrollHeight")
        if max_height:
            height = min(height, max_height)
        shot = self.driver.execute_cdp_cmd("Page.captureScreenshot", {
            "format": "png", "captureBeyondViewport": True,
            "clip": {"x": 0, "y": 0, "width": self.width, "height": height, "scale": scale}})
        Path(path).write_bytes(base64.b64decode(shot["data"]))
        return Path(path)


def main(argv):
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("html")
    parser.add_argument("png")
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--max-height", type=int, default=0, help="Top of the page only (CSS px).")
    parser.add_argument("--scale", type=float, default=1.0, help="Pixels per CSS px of the picture.")
    args = parser.parse_args(argv)
    why = missing()
    if why:
        sys.exit(f"cannot take a screenshot: {why}")
    with Browser(args.width) as browser:
        browser.open(args.html)
        browser.screenshot(args.png, max_height=args.max_height, scale=args.scale)
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main(sys.argv[1:])
