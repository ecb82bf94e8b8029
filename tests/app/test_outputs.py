"""The output set (uavplan/app/outputs.py): every output of a command is checked before the
work, made into a temporary next to its target, and moved into place with the others at the
commit, or not at all (issue 23, item 2)."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

from uavplan.app.outputs import OutputSet
from uavplan.errors import InputError
from uavplan.fileio import OutputFileError


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


class Gate:
    """An Interrupts double: records the commit point; ``pending`` raises there."""

    def __init__(self, pending: bool = False) -> None:
        self.pending = pending
        self.committed = 0

    def polled(self):  # type: ignore[no-untyped-def]
        raise AssertionError("not used")

    def commit_point(self) -> None:
        self.committed += 1
        if self.pending:
            raise KeyboardInterrupt


def test_nothing_changes_until_the_commit_then_everything_at_once(tmp_path: Path) -> None:
    (tmp_path / "old.plan").write_text("old mission")
    outputs = OutputSet()
    mission = outputs.file(tmp_path / "old.plan")
    report = outputs.file(tmp_path / "r.json")
    outputs.check()
    with outputs:
        mission.write_text("new mission")
        report.write_bytes(b"{}")
        # made, hidden next to their targets; the targets are as they were
        assert (tmp_path / "old.plan").read_text() == "old mission"
        assert not (tmp_path / "r.json").exists()
        temps = [n for n in listing(tmp_path) if n.startswith(".")]
        assert len(temps) == 2 and all(n.endswith(".tmp") for n in temps)
        written = outputs.commit()
    assert written == (str(tmp_path / "old.plan"), str(tmp_path / "r.json"))
    assert (tmp_path / "old.plan").read_text() == "new mission"
    assert (tmp_path / "r.json").read_bytes() == b"{}"
    assert listing(tmp_path) == ["old.plan", "r.json"]  # no temporary, no backup left


@pytest.mark.parametrize("ending", [RuntimeError, KeyboardInterrupt])
def test_an_error_or_an_interrupt_before_the_commit_leaves_nothing_new(
    tmp_path: Path, ending: type[BaseException]
) -> None:
    (tmp_path / "m.plan").write_text("old")
    outputs = OutputSet()
    mission = outputs.file(tmp_path / "m.plan")
    picture = outputs.file(tmp_path / "m.png")
    outputs.check()
    with pytest.raises(ending), outputs:
        mission.write_text("new")
        picture.write_bytes(b"png")
        raise ending
    assert listing(tmp_path) == ["m.plan"]
    assert (tmp_path / "m.plan").read_text() == "old"


def test_leaving_without_a_commit_removes_the_temporaries(tmp_path: Path) -> None:
    outputs = OutputSet()
    out = outputs.file(tmp_path / "a.txt")
    with outputs:
        out.write_text("made")
    assert listing(tmp_path) == []


def test_every_declared_output_must_be_made_before_the_commit(tmp_path: Path) -> None:
    outputs = OutputSet()
    a = outputs.file(tmp_path / "a.txt")
    outputs.file(tmp_path / "b.txt")
    with outputs:
        a.write_text("a")
        with pytest.raises(RuntimeError, match=r"b\.txt"):
            outputs.commit()
    assert listing(tmp_path) == []


def test_a_pending_interrupt_at_the_commit_point_moves_nothing(tmp_path: Path) -> None:
    gate = Gate(pending=True)
    outputs = OutputSet(gate)
    a = outputs.file(tmp_path / "a.txt")
    with pytest.raises(KeyboardInterrupt), outputs:
        a.write_text("a")
        outputs.commit()
    assert gate.committed == 1
    assert listing(tmp_path) == []


def test_the_commit_asks_the_interrupts_once(tmp_path: Path) -> None:
    gate = Gate()
    outputs = OutputSet(gate)
    a = outputs.file(tmp_path / "a.txt")
    with outputs:
        a.write_text("a")
        outputs.commit()
    assert gate.committed == 1 and listing(tmp_path) == ["a.txt"]


def test_a_rename_that_fails_halfway_undoes_the_ones_done(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The first output replaced an old file, the second fails: the old file comes back (from
    its hard link), the new one is removed, the error names the output that failed."""
    (tmp_path / "a.plan").write_text("old a")
    outputs = OutputSet()
    a = outputs.file(tmp_path / "a.plan")
    b = outputs.file(tmp_path / "b.json")
    c = outputs.file(tmp_path / "c.png")
    real_replace = os.replace
    calls = []

    def flaky(src: str, dst: str) -> None:
        calls.append(Path(dst).name)
        if Path(dst).name == "c.png":
            raise OSError(28, "No space left on device", str(dst))
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    with pytest.raises(OutputFileError, match=r"c\.png: cannot write: No space left") as caught:
        with outputs:
            a.write_text("new a")
            b.write_text("new b")
            c.write_bytes(b"png")
            outputs.commit()
    assert isinstance(caught.value, InputError)  # exit 2, one line
    monkeypatch.setattr(os, "replace", real_replace)
    assert calls[:3] == ["a.plan", "b.json", "c.png"]
    assert listing(tmp_path) == ["a.plan"]
    assert (tmp_path / "a.plan").read_text() == "old a"


def test_a_replaced_file_keeps_its_permission_bits(tmp_path: Path) -> None:
    target = tmp_path / "m.plan"
    target.write_text("old")
    target.chmod(0o640)
    outputs = OutputSet()
    out = outputs.file(target)
    with outputs:
        out.write_text("new")
        outputs.commit()
    assert stat.S_IMODE(target.stat().st_mode) == 0o640 and target.read_text() == "new"


# ---------------------------------------------------------------------------------------------
# The checks before the work


@pytest.mark.parametrize(
    ("path", "message"),
    [
        ("missing/m.plan", "folder .*missing.* does not exist"),
        ("a-file/m.plan", "is not a folder"),
        ("a-folder", "is a folder, not a file"),
    ],
)
def test_check_refuses_a_bad_output_path_and_leaves_nothing(
    tmp_path: Path, path: str, message: str
) -> None:
    (tmp_path / "a-file").write_text("x")
    (tmp_path / "a-folder").mkdir()
    outputs = OutputSet()
    outputs.file(tmp_path / "ok.json")
    outputs.file(tmp_path / path)
    with pytest.raises(OutputFileError, match=message):
        outputs.check()
    assert listing(tmp_path) == ["a-file", "a-folder"]


def test_check_refuses_two_outputs_that_are_one_file(tmp_path: Path) -> None:
    outputs = OutputSet()
    outputs.file(tmp_path / "x.json")
    outputs.file(tmp_path / "sub" / ".." / "x.json")
    (tmp_path / "sub").mkdir()
    with pytest.raises(InputError, match="are the same file"):
        outputs.check()


@pytest.fixture
def unwritable_folder(tmp_path: Path) -> Iterator[Path]:
    """A folder that takes no new file: a read-only one, or for root (who writes into those)
    sysfs's top, where nobody may create a file."""
    if os.geteuid() != 0:
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        yield ro
        ro.chmod(0o700)
        return
    sysfs = Path("/sys")
    try:
        (sysfs / ".uavplan-probe").touch()
    except OSError:
        yield sysfs
        return
    (sysfs / ".uavplan-probe").unlink()
    pytest.skip("no folder here refuses a new file")


def test_check_refuses_a_read_only_folder(unwritable_folder: Path) -> None:
    outputs = OutputSet()
    outputs.file(unwritable_folder / "m.plan")
    with pytest.raises(OutputFileError, match=r"m\.plan: cannot write"):
        outputs.check()
    outputs = OutputSet()
    outputs.folder(unwritable_folder / "bench")
    with pytest.raises(OutputFileError, match="bench: cannot write"):
        outputs.check()


# ---------------------------------------------------------------------------------------------
# An output folder (bench --out)


def test_a_new_folder_appears_whole_at_the_commit(tmp_path: Path) -> None:
    outputs = OutputSet()
    folder = outputs.folder(tmp_path / "bench")
    outputs.check()
    with outputs:
        folder.file("runs.csv").write_text("a,b\n")
        folder.file("summary.md").write_text("# t\n")
        assert not (tmp_path / "bench").exists()
        outputs.commit()
    assert listing(tmp_path) == ["bench"]
    assert listing(tmp_path / "bench") == ["runs.csv", "summary.md"]


def test_a_new_folder_is_not_left_behind_by_an_interrupt(tmp_path: Path) -> None:
    outputs = OutputSet()
    folder = outputs.folder(tmp_path / "bench")
    outputs.check()
    with pytest.raises(KeyboardInterrupt), outputs:
        folder.file("runs.csv").write_text("a,b\n")
        raise KeyboardInterrupt
    assert listing(tmp_path) == []


def test_files_go_into_an_existing_folder_beside_what_it_holds(tmp_path: Path) -> None:
    out = tmp_path / "bench"
    out.mkdir()
    (out / "runs.csv").write_text("old")
    (out / "notes.txt").write_text("mine")
    outputs = OutputSet()
    folder = outputs.folder(out)
    outputs.check()
    with outputs:
        folder.file("runs.csv").write_text("new")
        outputs.commit()
    assert listing(out) == ["notes.txt", "runs.csv"]
    assert (out / "runs.csv").read_text() == "new"


@pytest.mark.parametrize(
    ("path", "message"),
    [("a-file", "is a file, not a folder"), ("missing/bench", "does not exist")],
)
def test_check_refuses_a_bad_output_folder(tmp_path: Path, path: str, message: str) -> None:
    (tmp_path / "a-file").write_text("x")
    outputs = OutputSet()
    outputs.folder(tmp_path / path)
    with pytest.raises(OutputFileError, match=message):
        outputs.check()
    assert listing(tmp_path) == ["a-file"]
