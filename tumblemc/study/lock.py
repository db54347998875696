"""The lock a study holds on its result file while it writes it (``<result>.lock``)."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import Any

from tumblemc.io import StudyStateError, no_space

#: errors of a folder that cannot be written: read-only media or no permission
READ_ONLY_ERRNOS = (errno.EROFS, errno.EACCES, errno.EPERM)


class StudyLockedError(StudyStateError):
    """Another process is running the study that writes the same result file."""


class ReadOnlyOutputError(StudyStateError):
    """The folder of the result file cannot be written (read-only media, no permission): nothing was changed."""


class StudyLock:
    """An exclusive lock on a result file while a study writes it (``<result>.lock``, POSIX ``flock``).

    Released when the process ends, however it ends (``kill -9`` included), so a stale lock
    never blocks a rerun; removed on any exit Python sees (an exception, Ctrl-C, SIGTERM in
    ``study run``). A folder that cannot be written raises :class:`ReadOnlyOutputError`
    (a complete result there can still be reported); a full disk raises
    :class:`tumblemc.io.ResultWriteError` and leaves no lock file. Where ``fcntl`` does not
    exist (Windows) nothing is locked.
    """

    def __init__(self, result: Path) -> None:
        self.path = Path(result).with_name(Path(result).name + ".lock")
        self._fh: Any = None

    def __enter__(self) -> StudyLock:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows
            return self
        self.path.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fh = self._open()
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                fh.seek(0)
                holder = fh.read().strip() or "another process"
                fh.close()
                raise StudyLockedError(
                    f"{self.path.with_suffix('')} is being written by {holder}; wait for it to finish (rerun then resumes or "
                    "reports it complete) or give another --out"
                ) from None
            try:  # the holder before us may have removed the file between our open and our lock: lock the new one
                if os.stat(self.path).st_ino == os.fstat(fh.fileno()).st_ino:
                    break
            except FileNotFoundError:
                pass
            fh.close()
        try:
            os.ftruncate(fh.fileno(), 0)
            os.write(fh.fileno(), f"`tumblemc study run` (pid {os.getpid()}, started {_now()})".encode())
        except OSError as e:  # a disk full from the start: no empty lock left behind
            self.path.unlink(missing_ok=True)
            fh.close()
            if e.errno == errno.ENOSPC:
                raise no_space(self.path.parent, f"to start writing {self.path.with_suffix('').name}", "nothing was changed") from None
            raise
        self._fh = fh
        return self

    def _open(self) -> Any:
        """The lock file, opened (created if needed) without following a symlink.

        A link planted at ``<out>.lock`` is refused and its target left untouched.
        """
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
        except OSError as e:
            if self.path.is_symlink():
                raise StudyLockedError(
                    f"{self.path} is a symbolic link (to {os.readlink(self.path)}); tumblemc does not write through it. "
                    "Remove it, or give another --out"
                ) from None
            if e.errno in READ_ONLY_ERRNOS:
                raise ReadOnlyOutputError(
                    f"cannot write in {self.path.parent} ({e.strerror}); nothing was changed: "
                    "run where the folder is writable, or give another --out"
                ) from None
            raise StudyLockedError(f"cannot open the lock file {self.path}: {e.strerror}") from None
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            os.close(fd)
            raise StudyLockedError(f"{self.path} is not a regular file; remove it, or give another --out")
        return os.fdopen(fd, "r+")

    def __exit__(self, *exc: object) -> None:
        if self._fh is not None:
            self.path.unlink(missing_ok=True)  # while still held (__enter__ checks it locked the file on disk)
            self._fh.close()
            self._fh = None


def _now() -> str:
    import datetime as _dt

    return _dt.datetime.now().astimezone().replace(microsecond=0).isoformat()


__all__ = ["READ_ONLY_ERRNOS", "ReadOnlyOutputError", "StudyLock", "StudyLockedError"]
