"""Writing outputs so that nothing half-written is ever passed off as complete.

Every output is written to a hidden temporary beside it (``.NAME.PID-XXXX.partial.EXT``)
and moved into place only when complete; a set of outputs (a video's CSV, JSON and
figure) moves into place as a whole or not at all, and a folder (``atomic_folder``) is
made whole in ``.NAME.PID-XXXX.partial`` and renamed. An error names the output it
concerns. A run killed outright (SIGKILL, a power cut) can leave temporaries behind: the
next write of the same output removes those whose process is gone.
"""

from __future__ import annotations

import contextlib
import csv
import errno
import glob
import io
import json
import os
import re
import shutil
import stat
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

if sys.platform == "win32":
    import msvcrt

    def _lock(fd: int, wait: bool) -> None:
        # its first byte stands for the file; LK_LOCK tries for 10 s, then raises
        msvcrt.locking(fd, msvcrt.LK_LOCK if wait else msvcrt.LK_NBLCK, 1)

    def _unlock(fd: int) -> None:
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
else:
    import fcntl

    def _lock(fd: int, wait: bool) -> None:
        fcntl.flock(fd, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)

    def _unlock(fd: int) -> None:
        fcntl.flock(fd, fcntl.LOCK_UN)

__all__ = ["atomic_folder", "atomic_folder_outputs", "atomic_output", "atomic_outputs",
           "canonical_json", "csv_text", "error_text", "json_kind", "read_json", "read_text",
           "scratch_folder", "write_files", "write_text_atomic"]

_PARTIAL = re.compile(r"\.(?P<pid>\d+)-[^.]+\.partial")


def _temporary(target: Path) -> Path:
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}-",
                                suffix=f".partial{target.suffix}", dir=target.parent)
    os.close(fd)
    return Path(name)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def _remove_dead(parent: Path, prefix: str, suffix: str = "") -> None:
    """Remove the temporaries ``PREFIX.PID-XXXX.partialSUFFIX`` in `parent` (files or
    folders) whose process no longer runs."""
    for stale in parent.glob(f"{glob.escape(prefix)}.*.partial{glob.escape(suffix)}"):
        # the whole middle: `prefix` + ".x" is another output's prefix
        match = _PARTIAL.fullmatch(stale.name[len(prefix):len(stale.name) - len(suffix)])
        if match and not _alive(int(match["pid"])):
            if stale.is_dir():
                shutil.rmtree(stale, ignore_errors=True)
            else:
                stale.unlink(missing_ok=True)


def remove_stale_partials(target: Path) -> None:
    """Remove temporaries of the file `target` left by processes that no longer run."""
    _remove_dead(target.parent, f".{target.name}", target.suffix)


@contextlib.contextmanager
def scratch_folder(name: str) -> Iterator[Path]:
    """A private temporary folder in the system's temporary folder, removed afterwards;
    those a process killed outright left (``.NAME.PID-XXXX.partial``) go first."""
    parent = Path(tempfile.gettempdir())
    _remove_dead(parent, f".{name}")
    folder = Path(tempfile.mkdtemp(prefix=f".{name}.{os.getpid()}-", suffix=".partial",
                                   dir=parent))
    try:
        yield folder
    finally:
        _remove_tree(folder)


def _remove_tree(folder: Path) -> None:
    """Remove a temporary folder, to the end even when a stop (the exception a signal
    handler raises) comes half-way through: the stop is raised again afterwards. A run's
    stop can land in a job's cleanup (short jobs end often), and an interrupted removal
    would leave the folder behind."""
    try:
        shutil.rmtree(folder, ignore_errors=True)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise


def _named(exc: OSError, target: Path, verb: str = "write") -> OSError:
    """The same error, saying which output it concerns."""
    if exc.filename is not None and Path(exc.filename) == target:
        return exc
    return OSError(exc.errno, f"cannot {verb} {target}: {exc.strerror or exc}")


def _commit(pairs: Sequence[tuple[Path, Path]]) -> None:
    """Move each temporary onto its target: all of them, or (after a failure) none."""
    done: list[tuple[Path, Path | None]] = []  # target, backup of its previous content
    try:
        for tmp, target in pairs:
            backup = None
            if target.is_file():  # keep the previous content reachable until all moved
                backup = _temporary(target)
                try:
                    _link_or_copy(target, backup)
                except OSError:
                    backup.unlink(missing_ok=True)
                    raise
            try:
                os.replace(tmp, target)
            except OSError as exc:
                if backup is not None:
                    backup.unlink(missing_ok=True)
                raise _named(exc, target, "replace") from exc
            done.append((target, backup))
    except BaseException:
        for target, backup in reversed(done):
            if backup is None:
                target.unlink(missing_ok=True)
            else:
                os.replace(backup, target)
        raise
    for _target, backup in done:
        if backup is not None:
            backup.unlink(missing_ok=True)


def _link_or_copy(src: Path, dst: Path) -> None:
    dst.unlink()
    try:
        os.link(src, dst)
    except OSError:  # a file system without hard links
        shutil.copy2(src, dst)


@contextlib.contextmanager
def held_lock(lock: str | os.PathLike, busy: str | None = None) -> Iterator[None]:
    """Hold the lock file `lock` (made, with its folder, where absent) for the block, from
    any process in turn; where another holds it, wait for it, or with `busy` raise
    ValueError(busy) at once. The lock file stays: the lock is the process's, released
    when it ends however it ends."""
    lock = Path(lock)
    lock.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            _lock(fd, wait=busy is None)
        except OSError as exc:
            if busy is None or exc.errno not in (errno.EAGAIN, errno.EACCES):
                raise
            raise ValueError(busy) from None
        try:
            yield
        finally:
            _unlock(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_outputs(paths: Sequence[str | os.PathLike]) -> Iterator[list[Path]]:
    """Yield temporary paths beside `paths`; move them all into place if the block succeeds.

    On any error (a full disk, an interrupted run, a target that cannot be replaced) the
    temporaries are removed and every target keeps its previous content, or stays absent.
    """
    targets = [Path(p) for p in paths]
    temps: list[Path] = []
    made: list[Path] = []  # the folders made for the outputs, removed again on an error
    try:
        for target in targets:
            made += _make_parents(target)
            remove_stale_partials(target)
            temps.append(_temporary(target))
        yield temps
        mask = _umask()
        for tmp in temps:
            os.chmod(tmp, 0o666 & ~mask)  # mkstemp makes it private; outputs are not
        _commit(list(zip(temps, targets, strict=True)))
        made = []
    finally:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        for folder in reversed(made):
            with contextlib.suppress(OSError):  # no longer empty: another process's now
                folder.rmdir()


def _make_parents(target: Path) -> list[Path]:
    """Make the folders `target` goes in; return those that were not there, outermost
    first."""
    missing = [p for p in reversed(target.parents) if not p.exists()]
    target.parent.mkdir(parents=True, exist_ok=True)
    return missing


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike) -> Iterator[Path]:
    """`atomic_outputs` for one file; an error while writing it names the file."""
    with atomic_outputs([path]) as (tmp,):
        try:
            yield tmp
        except OSError as exc:
            raise _named(exc, Path(path)) from exc


@contextlib.contextmanager
def atomic_folder_outputs(folder: str | os.PathLike, names: Sequence[str]) -> Iterator[Path]:
    """Yield a hidden temporary folder inside `folder` in which to write the files `names`
    (by any means, under those names); move them all into `folder` if the block succeeds,
    as `atomic_outputs` does, for writers that take a folder rather than a file."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _remove_dead(folder, "")
    staging = Path(tempfile.mkdtemp(prefix=f".{os.getpid()}-", suffix=".partial", dir=folder))
    try:
        yield staging
        _commit([(staging / name, folder / name) for name in names])
    except OSError as exc:  # name the output as the user knows it, not its temporary
        def final(text: object) -> str:
            return str(text).replace(str(staging), str(folder))
        raise type(exc)(exc.errno, final(exc.strerror or exc),
                        *(() if exc.filename is None else (final(exc.filename),))) from exc
    finally:
        _remove_tree(staging)


@contextlib.contextmanager
def atomic_folder(dest: str | os.PathLike) -> Iterator[Path]:
    """Yield a hidden temporary folder beside `dest` in which to write a whole folder;
    rename it to `dest` if the block succeeds, else remove it.

    Raises:
        FileExistsError: `dest` appeared while the block ran (a rename would replace an
            empty folder unnoticed); it is left as it is.
    """
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    _remove_dead(dest.parent, f".{dest.name}")
    tmp = Path(tempfile.mkdtemp(prefix=f".{dest.name}.{os.getpid()}-", suffix=".partial",
                                dir=dest.parent))
    try:
        yield tmp
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes it private; the output is not
        if dest.exists():
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(dest))
        os.rename(tmp, dest)
    finally:
        _remove_tree(tmp)


def write_files(writers: Mapping[str | os.PathLike, Callable[[Path], None]]) -> None:
    """Write a set of files, each by its writer (called with a temporary path): the set
    moves into place as a whole, or not at all; an error names the file it concerns."""
    with atomic_outputs(list(writers)) as temps:
        for (target, write), tmp in zip(writers.items(), temps, strict=True):
            try:
                write(tmp)
            except OSError as exc:
                raise _named(exc, Path(target)) from exc


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write `text` to `path` atomically."""
    write_files({path: lambda tmp: tmp.write_text(text)})


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: The most bytes a file the tool reads as text (policy.json, a presets file, a curriculum,
#: run.json, a dataset's info.json) may hold: each is a few KB to a few MB, and a larger one
#: (/dev/zero, a video given by mistake) is refused before it fills the memory.
TEXT_LIMIT = 64 * 2**20


def read_text(path: str | os.PathLike, limit: int = TEXT_LIMIT) -> str:
    """The text (UTF-8) of the regular file `path`, at most `limit` bytes; ValueError, one
    line naming the file, where it is larger, cannot be read, is no regular file (a FIFO,
    a device) or is not text."""
    if not isinstance(path, str | os.PathLike):  # open() would take an int for a descriptor
        raise ValueError(f"{path!r} is not a file name")
    try:
        # O_NONBLOCK: opening a FIFO waits for a writer; it is refused below instead
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with open(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise ValueError(f"{path}: not a regular file, not a file this reads")
            data = f.read(limit + 1)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read it: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise ValueError(f"{path}: larger than {limit // 2**20} MB, not a file this reads")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})"
                         ) from None


def read_json(path: str | os.PathLike, limit: int = TEXT_LIMIT) -> Any:
    """The JSON value in the file `path` (at most `limit` bytes); ValueError, one line
    naming the file, where it cannot be read, is larger or is not JSON."""
    text = read_text(path, limit)
    try:
        return json.loads(text)
    except ValueError as exc:
        raise ValueError(f"{path}: not JSON ({exc})") from None
    except RecursionError:
        raise ValueError(f"{path}: JSON nested too deeply to be a file this reads") from None


_JSON_KINDS = {dict: "an object", list: "an array", str: "a string", bool: "a boolean",
               int: "an integer", float: "a number", type(None): "null"}


def json_kind(kind: type) -> str:
    """A JSON type's name in a message: "an object" (dict), "a string" (str)..."""
    return _JSON_KINDS[kind]


def error_text(exc: BaseException) -> str:
    """An error as a user reads it: an OSError's file and reason, without "[Errno N]"."""
    if isinstance(exc, OSError) and exc.strerror:
        if exc.filename is not None and str(exc.filename) not in exc.strerror:
            return f"{exc.filename}: {exc.strerror}"
        return exc.strerror
    return str(exc)


def canonical_json(value: Any) -> str:
    """JSON with sorted keys and a final newline: the same bytes for the same value."""
    return json.dumps(value, indent=2, sort_keys=True, allow_nan=False) + "\n"


def csv_text(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """Rows as CSV with the given columns; None becomes an empty cell."""
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(columns)
    for r in rows:
        writer.writerow(["" if r.get(c) is None else r[c] for c in columns])
    return out.getvalue()
