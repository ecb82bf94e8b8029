"""Every output of a command, committed together or not at all: :class:`OutputSet`.

A use case declares each file it will write (:meth:`OutputSet.file`; ``bench --out`` a folder
of files, :meth:`OutputSet.folder`) before its long work, and :meth:`OutputSet.check` asks of
every one the questions that can be answered in advance: its folder exists and takes a new
file, the path is not a folder (``bench --out``: not a file), no two outputs are one file.
A bad path is then an :class:`~uavplan.fileio.OutputFileError` (exit 2) before anything has
been planned, run or written.

Outputs never overwrite inputs: the use case names the files it reads
(:meth:`OutputSet.reads`: the scenario, the map it names, its obstacle files and DEM, the
mission file it was given), and an output that is one of them (through symbolic links, hard
links or another spelling of the path) is refused with the other checks, exit 2. Inputs
found only once the work has begun (a scenario's map, known once the scenario is read) are
checked as they are named, still before the long work. An output that is a symbolic link is
written through: its target gets the content, the link stays (:func:`~uavplan.fileio.write_target`).

Each output is made into a hidden temporary file next to its target (same folder, so the
same file system) as the work goes; a folder that does not exist yet is made as a hidden
temporary folder next to where it goes. Only when every declared output is made does
:meth:`OutputSet.commit` move them into place, one rename each, in a moment at the very end.
Until then nothing the user can see has changed: leaving the ``with`` block without a commit
(an error, an interrupt, an early return) removes every temporary, and the targets stay as
they were.

If a rename fails during the commit (a full disk, a folder put in the way meanwhile), those
done are undone: a replaced file comes back from a hard link made to it just before (on a
file system without hard links that one file keeps its new content, and the message says
so), a new file or folder is removed. The renames themselves are not interrupted: the use
case's :class:`~uavplan.app.feedback.Interrupts` (the CLI's Ctrl-C) is asked at the commit
point whether a Ctrl-C came first, and from there on a Ctrl-C is too late to undo the command.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import shutil
import stat
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from uavplan.app.feedback import Interrupts
from uavplan.errors import InputError
from uavplan.fileio import (
    InputFile,
    OutputFileError,
    check_folder,
    check_writable,
    create_temp,
    fsync_directory,
    output_error,
    same_file,
    write_target,
)


@dataclass(eq=False)
class _Folder:
    """A declared output folder; ``existed``: it was there when checked (else it is made as
    ``temp`` and renamed into place)."""

    target: Path
    shown: str
    existed: bool | None = None
    temp: Path | None = None


@dataclass(eq=False)
class _File:
    target: Path
    shown: str
    folder: _Folder | None = None
    temp: Path | None = None


@dataclass(eq=False)
class _Done:
    """A rename of the commit, and how to undo it."""

    shown: str
    target: Path
    backup: Path | None = None  # a hard link to the file it replaced
    replaced: bool = False  # it replaced a file (without a backup: not undoable)
    folder_temp: Path | None = None  # a new folder: where it came from


class Output:
    """One declared output file of an :class:`OutputSet`: made with :meth:`write_bytes` or
    :meth:`write_text` (into its temporary; the target changes only at the commit)."""

    def __init__(self, owner: OutputSet, entry: _File) -> None:
        self._owner = owner
        self._entry = entry

    @property
    def path(self) -> str:
        """The target as the user named it."""
        return self._entry.shown

    @property
    def made(self) -> bool:
        return self._entry.temp is not None

    def write_bytes(self, data: bytes) -> None:
        """Make the output (again: the previous content is dropped)."""
        self._owner._make(self._entry, data)

    def write_text(self, text: str, *, encoding: str = "utf-8") -> None:
        """Make the output from ``text``, byte for byte (line endings as given)."""
        self._owner._make(self._entry, text.encode(encoding))


class OutputFolder:
    """A declared output folder (``bench --out``): its files are declared with :meth:`file`,
    whenever the use case knows their names."""

    def __init__(self, owner: OutputSet, folder: _Folder) -> None:
        self._owner = owner
        self._folder = folder

    @property
    def path(self) -> str:
        return self._folder.shown

    def file(self, name: str) -> Output:
        """The output file ``name`` in this folder."""
        if not name or Path(name).name != name or name in (".", ".."):
            raise ValueError(f"not a file name: {name!r}")
        target = self._folder.target / name
        return self._owner._add(_File(write_target(target), str(target), self._folder))


@dataclass(eq=False)
class OutputSet:
    """Every output of one command (see the module doc). Use it as a context manager::

    outputs = OutputSet(feedback.interrupts)
    outputs.reads(request.source, role="the scenario")   # no output may be an input
    mission = outputs.file(request.output)
    outputs.check()                 # exit 2 now, before any long work
    scenario = load_scenario(request.source)
    outputs.reads(*scenario.files)  # its map, obstacle files, DEM: checked at once
    with outputs:                   # leaving without a commit removes every temporary
        ...                         # the long work
        mission.write_text(text)
        outputs.commit()            # every output in place, or none
    """

    interrupts: Interrupts | None = None
    _files: list[_File] = field(default_factory=list)
    _folders: list[_Folder] = field(default_factory=list)
    _inputs: list[InputFile] = field(default_factory=list)
    _checked: bool = False
    _committed: bool = False

    # -- declaring and checking ----------------------------------------------------------

    def file(self, path: str | os.PathLike[str]) -> Output:
        """Declare the output file ``path``."""
        shown = os.fspath(path)
        if isinstance(shown, bytes):  # pragma: no cover - the CLI passes str
            shown = shown.decode(errors="replace")
        return self._add(_File(write_target(shown), shown))

    def reads(
        self, *files: str | os.PathLike[str] | InputFile | None, role: str = "an input"
    ) -> None:
        """Name files the command reads (a plain path is ``role``; an
        :class:`~uavplan.fileio.InputFile` says what it is; None is skipped): no output may
        be one of them. Named after :meth:`check`, they are checked at once
        (:class:`~uavplan.fileio.OutputFileError`, exit 2)."""
        named: list[InputFile] = []
        for item in files:
            if isinstance(item, InputFile):
                named.append(item)
            elif item is not None:
                named.append(InputFile(str(os.fspath(item)), role))
        self._inputs.extend(named)
        if self._checked:
            for entry in self._files:
                _refuse_input(entry, named)

    def folder(self, path: str | os.PathLike[str]) -> OutputFolder:
        """Declare the output folder ``path`` (made at the commit if it does not exist)."""
        shown = os.fspath(path)
        if isinstance(shown, bytes):  # pragma: no cover - the CLI passes str
            shown = shown.decode(errors="replace")
        folder = _Folder(Path(shown), shown)
        self._folders.append(folder)
        return OutputFolder(self, folder)

    def _add(self, entry: _File) -> Output:
        if self._committed:
            raise RuntimeError("the outputs are already committed")
        if self._checked:  # a folder's file named late: it may not be an input either
            _refuse_input(entry, self._inputs)
        self._files.append(entry)
        return Output(self, entry)

    def check(self) -> None:
        """Raise :class:`~uavplan.fileio.OutputFileError` (exit 2) for the first output that
        cannot be written or that is a file the command reads (:meth:`reads`), and
        :class:`~uavplan.errors.InputError` when two outputs are one file. Call it before the
        long work; it leaves nothing behind."""
        for folder in self._folders:
            folder.existed = check_folder(folder.target)
        for entry in self._files:
            _refuse_input(entry, self._inputs)
        for index, entry in enumerate(self._files):
            if entry.folder is None:
                check_writable(entry.shown)
            for earlier in self._files[:index]:
                if same_file(earlier.target, entry.target):
                    raise InputError(
                        f"{earlier.shown} and {entry.shown} are the same file: name two files"
                    )
        self._checked = True

    # -- making ----------------------------------------------------------------------------

    def _make(self, entry: _File, data: bytes) -> None:
        if self._committed:
            raise RuntimeError("the outputs are already committed")
        self._drop(entry)
        folder = entry.folder
        try:
            if folder is not None and not self._folder_exists(folder):
                if folder.temp is None:
                    folder.temp = _make_temp_folder(folder.target)
                temp = folder.temp / entry.target.name
                fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _O_BINARY, 0o666)
            else:
                fd, temp = create_temp(entry.target.parent, entry.target.name)
        except OSError as err:
            raise output_error(err, entry.shown) from None
        entry.temp = temp
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
                handle.flush()
                os.fsync(handle.fileno())
        except OSError as err:
            self._drop(entry)
            raise output_error(err, entry.shown) from None

    @staticmethod
    def _folder_exists(folder: _Folder) -> bool:
        if folder.existed is None:  # not checked: ask now
            folder.existed = folder.target.is_dir()
        return folder.existed

    # -- committing ------------------------------------------------------------------------

    def commit(self) -> tuple[str, ...]:
        """Move every output into place (see the module doc); the paths written, in the
        order declared (a new folder's files under it). Every declared output must be made."""
        if self._committed:
            raise RuntimeError("the outputs are already committed")
        missing = [e.shown for e in self._files if e.temp is None]
        if missing:
            raise RuntimeError(f"outputs declared but not made: {', '.join(missing)}")
        if self.interrupts is not None:
            self.interrupts.commit_point()
        done: list[_Done] = []
        current = ""  # the output being moved, as the user named it
        try:
            for folder in self._folders:
                if folder.temp is not None:  # a new folder: one rename
                    current = folder.shown
                    os.rename(folder.temp, folder.target)
                    done.append(_Done(folder.shown, folder.target, folder_temp=folder.temp))
                    folder.temp = None
                    for entry in self._files:
                        if entry.folder is folder:
                            entry.temp = None
            for entry in self._files:
                if entry.temp is not None:
                    current = entry.shown
                    done.append(_replace(entry))
                    entry.temp = None
        except BaseException as exc:
            kept = _undo(done)
            self.discard()
            if isinstance(exc, OSError):
                err = output_error(exc, current)
                if kept:
                    err = OutputFileError(
                        f"{err.reason}; {', '.join(kept)} could not be restored and holds "
                        "the new content",
                        file=current,
                    )
                raise err from None
            raise
        for step in done:
            if step.backup is not None:
                with contextlib.suppress(OSError):
                    os.unlink(step.backup)
        for directory in {step.target.parent for step in done}:
            fsync_directory(directory)
        self._committed = True
        written = [e.shown for e in self._files]
        return tuple(written)

    # -- discarding ------------------------------------------------------------------------

    def discard(self) -> None:
        """Remove every temporary made so far (the targets are untouched)."""
        for entry in self._files:
            self._drop(entry)
        for folder in self._folders:
            if folder.temp is not None:
                shutil.rmtree(folder.temp, ignore_errors=True)
                folder.temp = None

    @staticmethod
    def _drop(entry: _File) -> None:
        if entry.temp is not None:
            with contextlib.suppress(OSError):
                os.unlink(entry.temp)
            entry.temp = None

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if not self._committed:
            self.discard()


def check_output(
    path: str | os.PathLike[str], *reads: str | os.PathLike[str] | InputFile | None
) -> None:
    """The checks of :meth:`OutputSet.check` for one output a use case writes its own way
    (``fly`` and ``simulate`` write their tracks whatever the flight's ending): it can be
    written, and it is none of the files the command ``reads`` (exit 2)."""
    outputs = OutputSet()
    outputs.reads(*reads)
    outputs.file(path)
    outputs.check()


def check_report_name(path: str | None) -> None:
    """``--report`` writes JSON: a name that does not end in ``.json`` (a scenario's
    ``.yaml``, a ``.plan`` typed where the report goes) is refused, exit 2."""
    if path is not None and Path(path).suffix.lower() != ".json":
        raise InputError("--report writes a JSON report; name the file *.json", file=path)


def _refuse_input(entry: _File, inputs: list[InputFile]) -> None:
    """Raise :class:`~uavplan.fileio.OutputFileError` (exit 2) when the output ``entry``
    is one of ``inputs`` (through links: :func:`~uavplan.fileio.same_file`)."""
    for source in inputs:
        if same_file(entry.shown, source.path):
            shown_source = "" if source.path == entry.shown else f" ({source.path})"
            raise OutputFileError(
                f"is {source.role}{shown_source}, which this command reads: an output never "
                "overwrites an input; name another file",
                file=entry.shown,
            )


_O_BINARY = getattr(os, "O_BINARY", 0)
_TEMP_ATTEMPTS = 100


def _make_temp_folder(target: Path) -> Path:
    """A new hidden folder next to ``target`` (``.NAME.XXXXXXXX.tmp``)."""
    for _ in range(_TEMP_ATTEMPTS):
        temp = target.parent / f".{target.name[:64]}.{secrets.token_hex(4)}.tmp"
        try:
            os.mkdir(temp)
        except FileExistsError:
            continue
        return temp
    raise FileExistsError(f"could not make a temporary folder next to {target}")


def _replace(entry: _File) -> _Done:
    """Rename ``entry``'s temporary over its target, keeping a hard link to the file it
    replaces (and its permission bits)."""
    assert entry.temp is not None
    target = entry.target
    try:
        info = os.lstat(target)
    except FileNotFoundError:
        info = None
    backup = None
    try:
        if info is not None:
            if stat.S_ISDIR(info.st_mode):
                raise IsADirectoryError(errno.EISDIR, "is a folder", str(target))
            if stat.S_ISREG(info.st_mode):
                os.chmod(entry.temp, stat.S_IMODE(info.st_mode))
            backup = _backup(target)
        os.replace(entry.temp, target)
    except BaseException:
        if backup is not None:
            with contextlib.suppress(OSError):
                os.unlink(backup)
        raise
    return _Done(entry.shown, target, backup=backup, replaced=info is not None)


def _backup(target: Path) -> Path | None:
    """A hard link to ``target`` next to it, or None where the file system has none."""
    for _ in range(_TEMP_ATTEMPTS):
        backup = target.parent / f".{target.name[:64]}.{secrets.token_hex(4)}.bak"
        try:
            os.link(target, backup, follow_symlinks=False)
        except FileExistsError:
            continue
        except (OSError, NotImplementedError):
            return None
        return backup
    return None


def _undo(done: list[_Done]) -> list[str]:
    """Undo the renames ``done`` (last first); the outputs that could not be restored."""
    kept: list[str] = []
    for step in reversed(done):
        try:
            if step.folder_temp is not None:
                os.rename(step.target, step.folder_temp)
                shutil.rmtree(step.folder_temp, ignore_errors=True)
            elif step.backup is not None:
                os.replace(step.backup, step.target)
            elif step.replaced:
                kept.append(step.shown)
            else:
                os.unlink(step.target)
        except OSError:
            kept.append(step.shown)
    return kept
