#!/usr/bin/env python3
"""Screenshots of the page of ``uavplan view`` for docs/view.md, taken by the test browser.

Plans each bundled mission as the docs do (``uavplan plan M -o M.plan --view M.html``),
opens the page in headless Chromium (tests/helpers/browser.py: Debian's ``chromium`` driven by
Playwright), moves the replay to the middle of the flight and writes
``docs/images/view-NAME.png`` (the whole page, 1600 px wide):

    python tools/view_screenshots.py                      # the three of docs/view.md
    python tools/view_screenshots.py paper-env1 --out /tmp

paper-env1 (the paper's first environment), helsinki-centre (the OpenStreetMap town) and
jacksboro-ridge (over a real DEM). A page that reports an error, or a console error, stops
the tool with a message: a screenshot of a broken page is never written.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from helpers.browser import Browser, unavailable  # noqa: E402

MISSIONS = ("paper-env1", "helsinki-centre", "jacksboro-ridge")


def page_of(name: str, folder: Path) -> Path:
    """Plan the bundled mission ``name`` with ``--view``: its page."""
    page = folder / f"{name}.html"
    cmd = [
        sys.executable, "-m", "uavplan", "plan", str(ROOT / "missions" / f"{name}.yaml"),
        "-o", f"{name}.plan", "--view", page.name, "-q",
    ]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, check=False, cwd=folder)
    if done.returncode != 0 or not page.is_file():
        raise SystemExit(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stderr}")
    return page


def screenshot(browser: Browser, page: Path, out: Path) -> None:
    loaded = browser.open(page)
    try:
        problem = loaded.view("V.error")
        if problem or loaded.errors:
            raise SystemExit(f"{page}: the page did not draw cleanly: {problem or loaded.errors}")
        last = int(loaded.page.locator("#replay").get_attribute("max") or 0)
        if last:  # the vehicle in the middle of its flight
            loaded.page.evaluate(
                "n => { const s = document.getElementById('replay'); s.value = String(n);"
                " s.dispatchEvent(new Event('input', {bubbles: true})); }",
                last // 2,
            )
            loaded.page.wait_for_function(f"window.uavplanView.frame === {last // 2}")
            loaded.page.wait_for_timeout(800)
        loaded.page.screenshot(path=str(out), full_page=True)
    finally:
        loaded.page.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", default=list(MISSIONS), help="bundled missions")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images")
    args = parser.parse_args(argv)
    why = unavailable()
    if why is not None:
        raise SystemExit(f"no browser: {why}")
    with tempfile.TemporaryDirectory() as tmp:
        browser = Browser()
        try:
            for name in args.names:
                out = args.out / f"view-{name}.png"
                screenshot(browser, page_of(name, Path(tmp)), out)
                print(f"{out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}")
        finally:
            browser.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
