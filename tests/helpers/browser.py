"""A headless Chromium for the page's tests and tools/view_screenshots.py.

Debian's ``chromium`` (``apt-get install chromium``), driven by Playwright from PyPI over
``executable_path``: Playwright never downloads a browser of its own here. Chromium starts
with a fresh user-data-dir and without the background services that would wait on a network
this machine does not have.

:func:`unavailable` says why the browser cannot run (None: it can). Tests skip with that
reason, unless ``UAVPLAN_REQUIRE_BROWSER=1`` (set by ``.ci/run``): then a missing browser is
a failure, so CI never passes by skipping them.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: where Debian's package puts the browser (UAVPLAN_CHROMIUM overrides)
CHROMIUM = os.environ.get("UAVPLAN_CHROMIUM", "/usr/bin/chromium")
#: the switches that keep a headless Chromium from waiting on the network or a GPU
CHROMIUM_ARGS = (
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-default-apps",
    "--disable-extensions",
    # WebGL on the CPU (SwiftShader): a headless browser without a GPU draws the 3-D view
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
)
#: how long a page may take to draw (ms): a loaded 2-core machine, a 6 MB page
READY_TIMEOUT_MS = 120_000
#: the environment variable that turns a skip into a failure (CI)
REQUIRE = "UAVPLAN_REQUIRE_BROWSER"


def required() -> bool:
    return os.environ.get(REQUIRE, "") not in ("", "0")


def unavailable() -> str | None:
    """Why the browser tests cannot run here (None: they can)."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright is not installed (pip install playwright)"
    if not (Path(CHROMIUM).is_file() and os.access(CHROMIUM, os.X_OK)):
        return f"no Chromium at {CHROMIUM} (apt-get install chromium)"
    return None


@dataclass
class Loaded:
    """A page opened in the browser: what its console said and what it asked the network."""

    page: Any
    console: list[tuple[str, str]] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)
    load_s: float = 0.0

    @property
    def errors(self) -> list[str]:
        return [text for kind, text in self.console if kind in ("error", "pageerror")]

    def view(self, expression: str) -> Any:
        """Evaluate ``expression`` in the page (``window.uavplanView`` is ``V``)."""
        return self.page.evaluate(
            f"(() => {{ const V = window.uavplanView; return ({expression}); }})()"
        )


class Browser:
    """One Chromium for many pages (:meth:`open`)."""

    def __init__(self) -> None:
        from playwright.sync_api import sync_playwright

        self._user_data = tempfile.mkdtemp(prefix="uavplan-chromium-")
        self._pw = sync_playwright().start()
        try:
            self._context = self._pw.chromium.launch_persistent_context(
                self._user_data,
                executable_path=CHROMIUM,
                args=list(CHROMIUM_ARGS),
                headless=True,
                viewport={"width": 1600, "height": 1000},
                offline=True,
            )
        except Exception:
            self._pw.stop()
            shutil.rmtree(self._user_data, ignore_errors=True)
            raise

    def open(self, path: str | os.PathLike[str], *, wait: bool = True) -> Loaded:
        """Open the file ``path``; with ``wait``, until the page says it is drawn (or
        failed: ``window.uavplanView.error``)."""
        import time

        page = self._context.new_page()
        loaded = Loaded(page)
        page.on("console", lambda m: loaded.console.append((m.type, m.text)))
        page.on("pageerror", lambda e: loaded.console.append(("pageerror", str(e))))
        page.on("request", lambda r: loaded.requests.append(r.url))
        t0 = time.perf_counter()
        page.goto(Path(path).resolve().as_uri())
        if wait:
            page.wait_for_function(
                "window.uavplanView && (window.uavplanView.ready || window.uavplanView.error)",
                timeout=READY_TIMEOUT_MS,
            )
        loaded.load_s = time.perf_counter() - t0
        return loaded

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._context.close()
        with contextlib.suppress(Exception):
            self._pw.stop()
        shutil.rmtree(self._user_data, ignore_errors=True)


@contextlib.contextmanager
def browser() -> Iterator[Browser]:
    b = Browser()
    try:
        yield b
    finally:
        b.close()


def canvas_pixels(loaded: Loaded, selector: str = "#scene3d") -> tuple[int, float]:
    """(distinct colours, their spread) in a screenshot of ``selector``: a blank or
    single-colour area has 1 colour and no spread."""
    import io

    import numpy as np
    from matplotlib import image

    png = loaded.page.locator(selector).screenshot()
    pixels = image.imread(io.BytesIO(png), format="png")[..., :3].reshape(-1, 3)
    distinct = len({tuple(p) for p in (pixels * 255).astype(np.uint8)[::7].tolist()})
    return distinct, float(pixels.std())
