"""Atomic file writes: a reader sees the old file or the complete new one, never a part.

The data goes to a temporary file in the target's directory (same file system, so the final
``os.replace`` is atomic), is flushed and fsynced, then renamed over the target; the
directory is fsynced too where the platform allows it. On any failure, including
KeyboardInterrupt, the temporary file is removed and the target is left untouched.

A failure names the user's path, never the temporary file: it raises
:class:`OutputFileError`, which is both an :class:`OSError` (for callers that catch those)
and an :class:`~uavplan.errors.InputError` (exit 2, one line). :func:`check_writable` asks the
same questions before any long work starts, so a command can refuse a bad output path before
it plans for a minute (and before it writes any of its other outputs).

A path that is a symbolic link is written through: the file the link points to gets the new
content and the link stays a link (:func:`write_target`). :class:`InputFile` names a file a
command reads, which none of its outputs may name (:func:`same_file`, through links).
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
from dataclasses import dataclass
from pathlib import Path

from uavplan.errors import InputError

_TEMP_ATTEMPTS = 100
#: the part of the target's name kept in the temporary file's name (NAME_MAX is 255 bytes)
_TEMP_NAME_CHARS = 64


class OutputFileError(InputError, OSError):
    """An output file cannot be written; the message names the user's path (exit 2)."""

    def __init__(self, reason: str, *, file: str, error_number: int | None = None) -> None:
        InputError.__init__(self, reason, file=file)
        self.message = f"{file}: {reason}"
        self.errno = error_number  # type: ignore[assignment]  # typeshed before 2024: int
        self.strerror = reason
        self.filename = file

    def __str__(self) -> str:
        # OSError's own str() would read "[Errno 2] ...: 'path'"; the user sees one message
        return self.message


@dataclass(frozen=True)
class InputFile:
    """A file a command reads (its scenario, the map the scenario names, a DEM, the mission
    file it was given): ``role`` says what it is in a message (``"the scenario"``,
    ``"the map of missions/x.yaml"``)."""

    path: str
    role: str = "an input"


def write_target(path: str | os.PathLike[str]) -> Path:
    """The file a write to ``path`` changes: ``path`` itself, or where it leads when it is a
    symbolic link (every link of a chain resolved): a link is written through, never
    replaced, and a dangling link's target is created."""
    named = Path(os.fspath(path))
    try:
        linked = named.is_symlink()
    except OSError:  # a name too long, a folder that cannot be read: the checks say so
        return named
    return Path(os.path.realpath(named)) if linked else named


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Do ``a`` and ``b`` name one file: the same path once links are resolved, or (both
    existing) the same inode, as a hard link or another spelling on a case-insensitive file
    system gives?"""
    real_a, real_b = os.path.realpath(os.fspath(a)), os.path.realpath(os.fspath(b))
    if os.path.normcase(real_a) == os.path.normcase(real_b):
        return True
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def check_writable(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputFileError` (an InputError, exit 2) unless ``path`` can be written.

    Checks, without leaving anything behind: the path is a sensible file name, it is not a
    folder, its folder exists and is a folder, and a file can be created in that folder (a
    real probe: permissions, read-only file systems and ACLs all answer). Call it for every
    output path before long work; the final write can still fail (a full disk), and then
    :func:`atomic_write_bytes` raises the same error type.
    """
    shown = os.fspath(path)
    if isinstance(shown, bytes):  # pragma: no cover - the CLI passes str
        shown = shown.decode(errors="replace")
    if not shown:
        raise OutputFileError("empty output file name", file="''")
    if "\x00" in shown:
        raise OutputFileError("the file name contains a NUL byte", file=repr(shown))
    target = write_target(shown)
    folder = target.parent
    try:
        info = os.stat(target)
    except FileNotFoundError:
        info = None
    except OSError as err:
        raise output_error(err, shown) from None
    if info is not None and stat.S_ISDIR(info.st_mode):
        raise OutputFileError("is a folder, not a file", file=shown)
    try:
        folder_info = os.stat(folder)
    except FileNotFoundError:
        reason = f"cannot write: folder {str(folder)!r} does not exist"
        raise OutputFileError(reason, file=shown) from None
    except OSError as err:
        raise output_error(err, shown) from None
    if not stat.S_ISDIR(folder_info.st_mode):
        raise OutputFileError(f"cannot write: {str(folder)!r} is not a folder", file=shown)
    if len(os.fsencode(target.name)) > _name_max(folder):
        raise OutputFileError("cannot write: the file name is too long", file=shown)
    try:
        fd, temp = create_temp(folder, target.name)
    except OSError as err:
        raise output_error(err, shown) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(temp)


def check_folder(path: str | os.PathLike[str]) -> bool:
    """Raise :class:`OutputFileError` (exit 2) unless files can be written into the folder
    ``path``: it is a folder that takes a new file, or it does not exist and its parent is a
    folder that takes a new entry (a real probe, as :func:`check_writable`). Returns whether
    the folder exists."""
    shown = os.fspath(path)
    if isinstance(shown, bytes):  # pragma: no cover - the CLI passes str
        shown = shown.decode(errors="replace")
    if not shown:
        raise OutputFileError("empty folder name", file="''")
    if "\x00" in shown:
        raise OutputFileError("the folder name contains a NUL byte", file=repr(shown))
    target = Path(shown)
    try:
        info = os.stat(target)
    except FileNotFoundError:
        info = None
    except OSError as err:
        raise output_error(err, shown) from None
    if info is not None and not stat.S_ISDIR(info.st_mode):
        raise OutputFileError("is a file, not a folder", file=shown)
    probe_in = target if info is not None else target.parent
    if info is None:
        try:
            parent = os.stat(probe_in)
        except FileNotFoundError:
            reason = f"cannot write: folder {str(probe_in)!r} does not exist"
            raise OutputFileError(reason, file=shown) from None
        except OSError as err:
            raise output_error(err, shown) from None
        if not stat.S_ISDIR(parent.st_mode):
            raise OutputFileError(f"cannot write: {str(probe_in)!r} is not a folder", file=shown)
    try:
        fd, temp = create_temp(probe_in, target.name or "out")
    except OSError as err:
        raise output_error(err, shown) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(temp)
    return info is not None


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically.

    Raises :class:`OutputFileError` (an ``OSError`` naming ``path``) on failure. A new file
    gets the usual permissions (0o666 minus the umask); an existing file keeps its
    permission bits. A symbolic link is written through (:func:`write_target`).
    """
    shown = os.fspath(path)
    if isinstance(shown, bytes):  # pragma: no cover - the CLI passes str
        shown = shown.decode(errors="replace")
    if "\x00" in shown:
        raise OutputFileError("the file name contains a NUL byte", file=repr(shown))
    target = write_target(shown)
    directory = target.parent
    try:
        st_mode: int | None = os.stat(target).st_mode
    except FileNotFoundError:
        st_mode = None
    except OSError as err:
        raise output_error(err, shown) from None
    if st_mode is not None and stat.S_ISDIR(st_mode):
        raise OutputFileError("is a folder, not a file", file=shown)
    mode = None if st_mode is None else stat.S_IMODE(st_mode)

    try:
        fd, temp = create_temp(directory, target.name)
    except OSError as err:
        raise output_error(err, shown) from None
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        if mode is not None:
            os.chmod(temp, mode)
        os.replace(temp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(temp)
        if isinstance(exc, OSError) and not isinstance(exc, OutputFileError):
            raise output_error(exc, shown) from None
        raise
    fsync_directory(directory)


def atomic_write_text(path: str | os.PathLike[str], text: str, *, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically, byte for byte: line endings are not translated."""
    atomic_write_bytes(path, text.encode(encoding))


def output_error(err: OSError, shown: str) -> OutputFileError:
    """The user's view of an OSError met while writing ``shown`` (never a temp file's name)."""
    if err.errno == errno.ENOENT:
        folder = str(Path(shown).parent)
        if os.path.isdir(folder):  # a folder that takes no new file (/proc, a vanished mount)
            reason = f"cannot write: no file can be made in folder {folder!r}"
        else:
            reason = f"cannot write: folder {folder!r} does not exist"
    elif err.errno == errno.ENOTDIR:
        reason = f"cannot write: {str(Path(shown).parent)!r} is not a folder"
    else:
        reason = f"cannot write: {err.strerror or type(err).__name__}"
    return OutputFileError(reason, file=shown, error_number=err.errno)


def _name_max(folder: Path) -> int:
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def create_temp(directory: Path, name: str, suffix: str = ".tmp") -> tuple[int, Path]:
    """Create and open a new hidden file ``.NAME.XXXXXXXX.tmp`` in ``directory`` (O_EXCL,
    0o666 & ~umask): the temporary of a target called ``name`` there."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    stem = name[:_TEMP_NAME_CHARS]
    for _ in range(_TEMP_ATTEMPTS):
        temp = directory / f".{stem}.{secrets.token_hex(4)}{suffix}"
        try:
            return os.open(temp, flags, 0o666), temp
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, f"could not create a temporary file in {directory}")


def fsync_directory(directory: Path) -> None:
    """Make the rename durable (POSIX); a no-op where directories cannot be opened."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):
            os.fsync(fd)
    finally:
        os.close(fd)
