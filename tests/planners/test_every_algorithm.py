"""Every ``--algorithm`` on every bundled scenario ends as a user-facing outcome: a route
(exit 0) or "no path" (exit 3 with a message), never exit 1 / "internal error" (issue 11:
``--algorithm de`` on ``missions/paper-env1.yaml`` used to exit 1, "waypoint 158 is not
above the ground")."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.config import PLANNERS
from uavplan.errors import EXIT_NO_PATH

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
SCENARIOS = sorted(MISSIONS.glob("*.yaml"))


def test_the_bundled_scenarios_are_there() -> None:
    assert len(SCENARIOS) >= 9


@pytest.mark.parametrize("algorithm", list(PLANNERS))
@pytest.mark.parametrize("scenario", SCENARIOS, ids=lambda p: p.stem)
@pytest.mark.slow
def test_no_internal_error(tmp_path: Path, scenario: Path, algorithm: str) -> None:
    out = tmp_path / "route.waypoints"
    args = ["plan", str(scenario), "-o", str(out), "--algorithm", algorithm]
    result = CliRunner().invoke(main, [*args, "--iterations", "3", "--population", "6", "-q"])
    text = result.output + (str(result.exception) if result.exception else "")
    assert "internal error" not in text.lower(), text
    assert "Traceback" not in text, text
    assert result.exit_code in (0, EXIT_NO_PATH), text
    if result.exit_code == 0:
        assert out.is_file() and out.stat().st_size > 0
    else:
        assert "error" in result.output.lower() and len(result.output.strip()) > 10, text
