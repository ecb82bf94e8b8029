"""The page: one self-contained HTML file, plotly.js and the document inlined.

Nothing is fetched when the page opens: no script, no style sheet, no font (system fonts),
no map tiles. The drawing library is plotly.js, read from the ``plotly`` Python package
(its wheel ships ``package_data/plotly.min.js``, MIT licence); ``pip install
'uavplan[view]'`` brings it. docs/view.md says why this library and what the page weighs.
"""

from __future__ import annotations

import html
import importlib.util
import json
from pathlib import Path
from typing import Any

from uavplan.errors import InputError

__all__ = ["ViewerMissing", "page_html", "plotly_script"]

_HERE = Path(__file__).resolve().parent


class ViewerMissing(InputError):
    """The page's drawing library is not installed (exit 2, with how to install it)."""


def plotly_script() -> tuple[str, str]:
    """(plotly.js, its version) from the installed ``plotly`` package, without importing the
    package (its Python side is not needed). Raises :class:`ViewerMissing` when it is not
    installed."""
    spec = importlib.util.find_spec("plotly")
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    for where in locations:
        path = Path(where) / "package_data" / "plotly.min.js"
        if path.is_file():
            text = path.read_text(encoding="utf-8")
            version = "unknown"
            head = text[:200]
            if "plotly.js v" in head:
                version = head.split("plotly.js v", 1)[1].split()[0]
            return text, version
    raise ViewerMissing(
        "the interactive page needs plotly.js, which the optional extra brings: "
        "pip install 'uavplan[view]' (or pip install plotly)"
    )


def _inline_json(document: dict[str, Any]) -> str:
    """JSON safe inside a <script> element (no ``</``, no ``<!--``)."""
    text = json.dumps(document, separators=(",", ":"), allow_nan=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _inline_script(text: str) -> str:
    """A script's text safe inside a <script> element."""
    return text.replace("</script", "<\\/script").replace("</SCRIPT", "<\\/SCRIPT")


def page_html(document: dict[str, Any], *, plotly: tuple[str, str] | None = None) -> str:
    """The whole page for ``document`` (:func:`uavplan.view.build.mission_document` or
    :func:`~uavplan.view.build.scenario_document`)."""
    script, version = plotly if plotly is not None else plotly_script()
    own = (_HERE / "page.js").read_text(encoding="utf-8")
    style = (_HERE / "page.css").read_text(encoding="utf-8")
    title = html.escape(str(document.get("title", "uavplan view")))
    source = html.escape(str(document.get("source", "")))
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="uavplan view (plotly.js {html.escape(version)})">
<title>{title}</title>
<style>
{style}</style>
</head>
<body>
<div id="page-error" hidden></div>
<header>
<h1>{title}</h1>
<div class="source">{source}</div>
<ul id="verdict"></ul>
</header>
<main>
<div id="scene3d"></div>
<aside><h2>Legs (least clearance)</h2><table id="legs"></table></aside>
</main>
<div id="replay-box" hidden>
<button id="play" type="button">▶ play</button>
<input id="replay" type="range" min="0" max="0" value="0" step="1" aria-label="replay">
<span id="readout"></span>
</div>
<div id="profile"></div>
<footer>uavplan view — drag to turn, scroll to zoom, hover a waypoint or an obstacle. Works
offline: everything is in this file (plotly.js {html.escape(version)}, MIT licence).</footer>
<script id="uavplan-data" type="application/json">{_inline_json(document)}</script>
<script>{_inline_script(script)}</script>
<script>{_inline_script(own)}</script>
</body>
</html>
"""
