"""What a file given where a scenario is expected is: a mission file or a map export given
by mistake is named as such, with the option that takes it, instead of the scenario reader's
complaint about its first key (``fileType: unknown key``, ``(top level): must be a mapping``).

The extension decides first (``.plan``, ``.waypoints``, ``.geojson``, ``.kml``); a file with
another name is looked at only when the scenario reader has refused it (its first bytes: a
``QGC WPL`` header, a QGroundControl plan's ``"fileType": "Plan"``), so a scenario is read
exactly as before.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from uavplan.errors import InputError, ScenarioError
from uavplan.scenario import Scenario, load_scenario, load_site

#: how much of a file is looked at to recognise a mission file
_SNIFF_BYTES = 4096
_PLAN_JSON = re.compile(rb'"fileType"\s*:\s*"Plan"')


def mission_kind(path: str) -> str | None:
    """``"plan"`` (a QGroundControl plan), ``"waypoints"`` (a QGC WPL file), ``"export"`` (a
    GeoJSON / KML map export) from the name alone, else None."""
    suffix = Path(path).suffix.lower()
    return {".plan": "plan", ".waypoints": "waypoints", ".geojson": "export", ".kml": "export"}.get(
        suffix
    )


def sniff_mission_kind(path: str) -> str | None:
    """``"plan"`` or ``"waypoints"`` from the first bytes of the file, else None."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(_SNIFF_BYTES)
    except OSError:
        return None
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if text.startswith(b"QGC WPL"):
        return "waypoints"
    if text.startswith(b"{") and _PLAN_JSON.search(head):
        return "plan"
    return None


#: command → kind → what to do instead (the message's second half)
_ADVICE = {
    "plan": {
        "waypoints": "plan reads a scenario (YAML), or a QGroundControl .plan to reroute; "
        "convert this one to a .plan first (uavplan convert {file} {stem}.plan) and plan "
        "that, with --scenario S for the obstacles of a scenario",
        "plan": "plan reroutes a QGroundControl plan only when its name ends in .plan; "
        "rename it {stem}.plan (with --scenario S for the obstacles of a scenario)",
        "export": "a map export is written, not read; plan a scenario (YAML), or reroute a "
        "QGroundControl .plan (with --scenario S for the obstacles of a scenario)",
    },
    "validate": {
        "waypoints": "check it against a scenario: uavplan validate {file} --scenario S",
        "plan": "check it against a scenario (uavplan validate {file} --scenario S), or name "
        "it {stem}.plan to check it against its own geofence",
        "export": "a map export is written, not read; validate a scenario, or a mission "
        "file with --scenario S",
    },
    "render": {
        "waypoints": "draw it over a scenario: uavplan render S --mission {file} -o {stem}.png",
        "plan": "draw it over a scenario (uavplan render S --mission {file} -o {stem}.png), "
        "or name it {stem}.plan to draw it with its own geofence",
        "export": "a map export is written, not read; render a scenario (--mission draws a "
        ".plan or .waypoints mission over it)",
    },
    "view": {
        "waypoints": "view it in a scenario: uavplan view {file} --scenario S -o {stem}.html",
        "plan": "view it in a scenario: uavplan view {file} --scenario S -o {stem}.html",
        "export": "a map export is written, not read; view a scenario, or a mission file "
        "with --scenario S",
    },
    "bench": {
        "waypoints": "bench runs the planners on scenarios (YAML)",
        "plan": "bench runs the planners on scenarios (YAML)",
        "export": "bench runs the planners on scenarios (YAML)",
    },
}
_WHAT = {
    "waypoints": "a mission file (QGC WPL waypoints)",
    "plan": "a mission file (a QGroundControl plan)",
    "export": "a map export",
}


def not_a_scenario(path: str, kind: str, command: str) -> InputError:
    """The error for a ``kind`` file given to ``command`` as its scenario."""
    advice = _ADVICE.get(command, _ADVICE["bench"])[kind]
    advice = advice.format(file=path, stem=Path(path).stem)
    return InputError(f"this is {_WHAT[kind]}, not a scenario: {advice}", file=path)


def load_scenario_file(path: str, command: str, *, site: bool = False) -> Scenario:
    """The scenario file ``path`` given to ``command``; a mission file or a map export is
    refused with a message that says what it is and what takes it. ``site``: the scenario a
    mission is checked against (a survey scenario's site too: :func:`load_site`)."""
    kind = mission_kind(path)
    if kind is not None:
        raise not_a_scenario(path, kind, command)
    try:
        return load_site(path) if site else load_scenario(path)
    except ScenarioError:
        sniffed = sniff_mission_kind(os.fspath(path))
        if sniffed is not None:
            raise not_a_scenario(path, sniffed, command) from None
        raise
