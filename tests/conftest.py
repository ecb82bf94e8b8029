"""Suite-wide set-up.

click before 8.2 mixed standard error into ``CliRunner``'s output unless asked not to, and
then had no ``Result.stderr``; click 8.2 keeps the two apart and shows both in ``output``.
The suite is written against 8.2's runner; on an older click (the project declares
``click>=8.1``, and CI runs the lowest declared versions too) the runner is given 8.2's
behaviour here, so the same assertions hold on both ends of the range.
"""

from __future__ import annotations

import inspect
import shutil
from pathlib import Path
from typing import Any

import click.testing
import pytest
from helpers.terrain_helpers import RIDGE_FRAMES

if "mix_stderr" in inspect.signature(click.testing.CliRunner.__init__).parameters:

    class _Result(click.testing.Result):
        @property
        def output(self) -> str:  # type: ignore[override]
            # 8.2: "the terminal output", standard output and error as the user saw them
            return self.stdout + (self.stderr if self.stderr_bytes is not None else "")

    class _CliRunner(click.testing.CliRunner):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            kwargs.setdefault("mix_stderr", False)
            super().__init__(*args, **kwargs)

        def invoke(self, *args: Any, **kwargs: Any) -> click.testing.Result:
            result = super().invoke(*args, **kwargs)
            result.__class__ = _Result
            return result

    click.testing.CliRunner = _CliRunner  # type: ignore[misc]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The tests that fly the real firmware (marker ``sitl``) are in the slow tier too: the
    quick tier (``pytest -m "not slow"``) starts no SITL."""
    for item in items:
        if item.get_closest_marker("sitl") is not None:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def ridge_plans(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with the bundled terrain scenario (missions/jacksboro-ridge.yaml) in each
    altitude frame, ``FRAME.yaml`` beside its DEM, each planned briefly by the CLI into
    ``FRAME.plan`` with its ``FRAME.json`` report. Planned once for the whole run: modules
    copy the folder (``ridge_frames``) and write their own outputs into the copy."""
    pytest.importorskip("rasterio")
    from click.testing import CliRunner

    from uavplan.cli import main

    root = Path(__file__).resolve().parents[1]
    folder = tmp_path_factory.mktemp("ridge-plans")
    shutil.copy(root / "maps" / "jacksboro-fault-dem.tif", folder / "dem.tif")
    text = (root / "missions" / "jacksboro-ridge.yaml").read_text(encoding="utf-8")
    text = text.replace("../maps/jacksboro-fault-dem.tif", "dem.tif")
    for altitude in RIDGE_FRAMES:
        scenario = folder / f"{altitude}.yaml"
        scenario.write_text(text.replace("altitude: terrain", f"altitude: {altitude}"))
        args = ["plan", str(scenario), "-o", str(folder / f"{altitude}.plan"), "-q"]
        args += ["--iterations", "40", "--report", str(folder / f"{altitude}.json")]
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 0, result.output
    return folder


@pytest.fixture(scope="module")
def ridge_frames(ridge_plans: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The module's own copy of ``ridge_plans``, for its outputs: each frame's scenario."""
    folder = tmp_path_factory.mktemp("ridge") / "ridge"
    shutil.copytree(ridge_plans, folder)
    return {altitude: folder / f"{altitude}.yaml" for altitude in RIDGE_FRAMES}
