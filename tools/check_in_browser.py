"""Open the built docs and a report in headless Chromium, screenshot them, and fail on
what a reader would see broken: a console error, an image that did not load, or maths
left as raw TeX (``make docs-check``).

The site is served from 127.0.0.1 (a built mkdocs site needs a server for its search);
the report is opened as a file, as a reader opens it. Chromium resolves no other host
(``--host-resolver-rules``), so anything a page tried to fetch from the network would
fail and show as a console error. Needs Debian's ``chromium`` and ``chromium-driver``
and the ``selenium`` package (``make docs-check`` installs it).

    python tools/check_in_browser.py --site site --report results/report.html \
        --shots site-shots
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import functools
import http.server
import shutil
import sys
import tempfile
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.chrome.service import Service

#: Chromium's flags: headless, nothing fetched in the background, no host but loopback.
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1",
)
#: Pages of the site that hold maths: each must show some, typeset.
MATHS_PAGES = ("paper-notes/", "results/", "figures/", "neural/", "ablation/")

#: Resolves with "ok" once MathJax has typeset the page (or at once where it is absent).
WAIT_FOR_MATHS = """
const done = arguments[arguments.length - 1];
if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
  MathJax.startup.promise.then(() => done("ok"), (e) => done("MathJax failed: " + e));
} else { done("no MathJax"); }
"""
#: What the page shows: images that did not load, TeX left in its text, typeset formulas.
INSPECT = r"""
const skip = new Set(["SCRIPT", "STYLE", "CODE", "PRE", "TEXTAREA", "NOSCRIPT"]);
const tex = /\\\(|\\\)|\\\[|\\\]|\$\$|\\(frac|theta|sqrt|alpha|gamma|mu|sigma|dot|lvert)\b/;
const raw = [];
const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT, {
  acceptNode(node) {
    for (let e = node.parentElement; e; e = e.parentElement) {
      if (skip.has(e.tagName) || e.tagName.toLowerCase() === "mjx-container") {
        return NodeFilter.FILTER_REJECT;
      }
    }
    return NodeFilter.FILTER_ACCEPT;
  },
});
for (let n = walker.nextNode(); n; n = walker.nextNode()) {
  if (tex.test(n.textContent)) raw.push(n.textContent.trim().slice(0, 80));
}
for (const e of document.querySelectorAll(".arithmatex")) {
  if (!e.querySelector("mjx-container")) raw.push("untypeset: " + e.textContent.slice(0, 80));
}
const broken = Array.from(document.images)
  .filter((i) => !(i.complete && i.naturalWidth > 0))
  .map((i) => (i.currentSrc || i.src).slice(0, 120));
return {
  raw: raw,
  broken: broken,
  maths: document.querySelectorAll("mjx-container").length,
  images: document.images.length,
};
"""


@dataclass
class Verdict:
    """What one page showed."""

    url: str
    errors: list[str] = field(default_factory=list)
    maths: int = 0
    images: int = 0

    @property
    def ok(self) -> bool:
        return not self.errors


def browser(profile: Path) -> webdriver.Chrome:
    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    for flag in (*FLAGS, f"--user-data-dir={profile}", "--window-size=1280,1600"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver_path = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    driver = webdriver.Chrome(options=options, service=Service(executable_path=driver_path))
    driver.set_script_timeout(60)
    driver.set_page_load_timeout(60)
    return driver


def inspect(driver: webdriver.Chrome, url: str, *, wants_maths: bool = False) -> Verdict:
    verdict = Verdict(url)
    driver.get(url)
    state = driver.execute_async_script(WAIT_FOR_MATHS)
    if state not in ("ok", "no MathJax"):
        verdict.errors.append(str(state))
    seen = driver.execute_script(INSPECT)
    verdict.maths, verdict.images = int(seen["maths"]), int(seen["images"])
    verdict.errors += [f"raw TeX: {t!r}" for t in seen["raw"]]
    verdict.errors += [f"image not loaded: {src}" for src in seen["broken"]]
    if wants_maths and verdict.maths == 0:
        verdict.errors.append("no typeset maths on a page that has some")
    for entry in driver.get_log("browser"):
        if entry.get("level") == "SEVERE":
            verdict.errors.append(f"console: {entry.get('message', '')[:300]}")
    return verdict


def screenshot(driver: webdriver.Chrome, path: Path, *, full: bool) -> None:
    """A PNG of the viewport, or of the whole page with ``full``."""
    shot = driver.execute_cdp_cmd(
        "Page.captureScreenshot", {"format": "png", "captureBeyondViewport": full}
    )
    path.write_bytes(base64.b64decode(shot["data"]))


@contextlib.contextmanager
def serve(folder: Path) -> Iterator[str]:
    """``folder`` over HTTP on 127.0.0.1 (a free port), for as long as the block runs."""
    handler = functools.partial(QuietHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass


def site_pages(site: Path) -> list[str]:
    """Every page of a built site, as its URL path (``paper-notes/``, ``""`` the home)."""
    pages = []
    for index in sorted(site.rglob("index.html")):
        rel = index.parent.relative_to(site).as_posix()
        if rel.startswith(("assets", "search")):
            continue
        pages.append("" if rel == "." else rel + "/")
    return pages


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--site", type=Path, help="a built mkdocs site (make docs)")
    parser.add_argument("--report", type=Path, action="append", default=[], help="report pages")
    parser.add_argument("--shots", type=Path, required=True, help="folder for the screenshots")
    args = parser.parse_args(argv)
    args.shots.mkdir(parents=True, exist_ok=True)
    verdicts: list[Verdict] = []
    with tempfile.TemporaryDirectory(prefix="striatal-chromium-") as profile:
        driver = browser(Path(profile))
        try:
            for report in args.report:
                v = inspect(driver, report.resolve().as_uri(), wants_maths=True)
                screenshot(driver, args.shots / f"{report.stem}.png", full=False)
                screenshot(driver, args.shots / f"{report.stem}-full.png", full=True)
                verdicts.append(v)
            if args.site is not None:
                with serve(args.site) as root:
                    for page in site_pages(args.site):
                        v = inspect(driver, root + page, wants_maths=page in MATHS_PAGES)
                        if page in ("", *MATHS_PAGES):
                            name = page.strip("/") or "index"
                            screenshot(driver, args.shots / f"site-{name}.png", full=False)
                        verdicts.append(v)
        finally:
            driver.quit()
    for v in verdicts:
        status = "ok  " if v.ok else "FAIL"
        print(f"{status} {v.url}: {v.images} images, {v.maths} typeset formulas")
        for e in v.errors:
            print(f"     {e}")
    failed = [v for v in verdicts if not v.ok]
    print(f"{len(verdicts) - len(failed)} passed, {len(failed)} failed")
    print(f"screenshots in {args.shots}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
