"""Every file the tools write goes through here, and is written whole or not at all.

- write_file(path, text) (compare --json): a temporary file in the target's
  own directory, written, flushed and fsync'ed, then renamed over the target
  (os.replace, atomic within one file system), then the directory fsync'ed so
  that the rename survives a crash. A failure removes the temporary and leaves
  the target as it was.
- write_directory(path, files) (report --out): a report is a set of files that
  refer to each other (report.md links figures/*.svg, whose names follow the
  inputs), so writing each file atomically could still leave a new page
  beside old figures, or figures of an earlier report that nothing links.
  The whole report is built in a temporary sibling directory (same file
  system, each file fsync'ed) and renamed into place: a reader sees the old
  report or the new one. An earlier report in the way is renamed aside first
  and removed once the new one is in place (put back if that rename fails).
- check_file_target / check_directory_target: the command line calls them
  before any work. They create and remove a probe where the output will go:
  a permission check alone says yes to root under /proc, where nothing can be
  created.

A location that cannot be written raises OutputError: one line '<path>: <problem>'
(exit status 2, like any bad input).
"""
from __future__ import annotations

import os
import shutil
import tempfile
from typing import Callable


class OutputError(Exception):
    """An output location the tools cannot write. str() is one line: '<path>: <problem>'."""

    def __init__(self, path: str, problem: str):
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _cannot(path: str, error: OSError, what: str = "write") -> OutputError:
    return OutputError(path, f"cannot {what}: {error.strerror or error}")


def _write_whole(handle: int, text: str) -> None:
    """Writes text to an open descriptor, flushes it to the disk and closes it."""
    with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
        stream.write(text)
        stream.flush()
        os.fsync(stream.fileno())


def _fsync_directory(directory: str) -> None:
    handle = os.open(directory, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(handle)
    finally:
        os.close(handle)


def _probe(path: str, directory: str) -> None:
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".lockstep-probe-", dir=directory))
    except OSError as error:
        raise OutputError(path, f"cannot create anything in {directory}: {error.strerror or error}") from None


# ---------------------------------------------------------------- checks before any work

def check_file_target(path: str) -> None:
    """A file can be created at path: its directory exists and takes a new file, and path is no directory."""
    if os.path.isdir(path):
        raise OutputError(path, "is a directory: give a file name")
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise OutputError(path, f"its directory {directory} does not exist")
    _probe(path, directory)


# ---------------------------------------------------------------- a report directory

# What `lockstep report` writes into its directory: the two pages and the figures they show (report.py and
# its templates take these names).
HTML_PAGE, MARKDOWN_PAGE = "report.html", "report.md"
PAGES = (HTML_PAGE, MARKDOWN_PAGE)
FIGURES_DIRECTORY = "figures"


def foreign_entries(directory: str) -> list[str]:
    """What a directory holds besides a report's pages and figures (a report replaces only a report)."""
    foreign = []
    for name in os.listdir(directory):
        path = os.path.join(directory, name)
        if name == FIGURES_DIRECTORY and os.path.isdir(path) and not os.path.islink(path):
            foreign += [os.path.join(name, figure) for figure in os.listdir(path)
                        if not (figure.endswith(".svg") and os.path.isfile(os.path.join(path, figure)))]
        elif not (name in PAGES and os.path.isfile(path)):
            foreign.append(name)
    return foreign


def check_directory_target(path: str, foreign_entries: Callable[[str], list[str]] = foreign_entries) -> None:
    """A directory can be put at path: its parent exists and takes a new entry, and path is absent, empty,
    or holds only what foreign_entries(path) does not list (an earlier report, which is replaced)."""
    target = os.path.realpath(path)
    parent, name = os.path.split(target)
    if not name:
        raise OutputError(path, "give a directory to create, not the root")
    if os.path.lexists(path) and not os.path.isdir(target):
        raise OutputError(path, "is a file, not a directory")
    if not os.path.isdir(parent):
        raise OutputError(path, f"its parent directory {parent} does not exist")
    if os.path.isdir(target):
        here = os.path.realpath(os.getcwd())
        if here == target or here.startswith(target + os.sep):
            raise OutputError(path, "is the current directory or holds it: give a directory beside it")
        try:
            foreign = foreign_entries(target)
        except OSError as error:
            raise _cannot(path, error, "read it") from None
        if foreign:
            raise OutputError(path, f"holds {', '.join(sorted(foreign)[:3])}{' ...' if len(foreign) > 3 else ''}, "
                                    "which is not part of a lockstep report: give a new or an empty directory")
    _probe(path, parent)


# ---------------------------------------------------------------- writing

def write_file(path: str, text: str) -> None:
    """path holds text, whole, or is left as it was."""
    directory = os.path.dirname(os.path.abspath(path))
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.", suffix=".tmp", dir=directory)
    except OSError as error:
        raise _cannot(path, error) from None
    try:
        _write_whole(handle, text)
        os.chmod(temporary, 0o666 & ~_umask())  # mkstemp's 0600 is for the temporary only
        os.replace(temporary, path)
        _fsync_directory(directory)
    except BaseException as error:
        if os.path.lexists(temporary):
            os.unlink(temporary)
        if isinstance(error, OSError):
            raise _cannot(path, error) from None
        raise


def _publish(building: str, target: str) -> None:
    """Renames the finished directory to target, replacing an earlier one there."""
    parent, name = os.path.split(target)
    if not (os.path.isdir(target) and os.listdir(target)):
        os.replace(building, target)  # target absent or an empty directory: one atomic rename
        return
    aside = tempfile.mkdtemp(prefix=f".{name}.", suffix=".old", dir=parent)
    os.replace(target, aside)  # onto the empty placeholder
    try:
        os.replace(building, target)
    except BaseException:
        os.replace(aside, target)
        raise
    shutil.rmtree(aside, ignore_errors=True)


def write_directory(path: str, files: dict[str, str]) -> None:
    """path becomes a directory holding exactly files ({relative path: text}), whole, or is left as it was."""
    target = os.path.realpath(path)
    parent, name = os.path.split(target)
    try:
        building = tempfile.mkdtemp(prefix=f".{name}.", suffix=".building", dir=parent)
    except OSError as error:
        raise _cannot(path, error) from None
    try:
        directories = {building}
        for relative, text in files.items():
            file_path = os.path.join(building, relative)
            directory = os.path.dirname(file_path)
            if directory not in directories:
                os.makedirs(directory)
                directories.add(directory)
            _write_whole(os.open(file_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), text)
        for directory in sorted(directories, reverse=True):  # the entries of each, before its parent's
            _fsync_directory(directory)
        os.chmod(building, 0o777 & ~_umask())  # mkdtemp's 0700 is for the temporary only
        _publish(building, target)
        _fsync_directory(parent)
    except BaseException as error:
        shutil.rmtree(building, ignore_errors=True)
        if isinstance(error, OSError):
            raise _cannot(path, error) from None
        raise
