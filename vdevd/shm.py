"""The daemon's shared-memory segment: the backing of its regions' passive memory (decision 0010).

One file per daemon in a tmpfs directory (/dev/shm), created with O_CREAT|O_EXCL, mode 0o600, and
held under an exclusive `flock` for the daemon's life. Its first page is a header whose byte 0 is
LIVE while the daemon serves it and 0 once it has stopped or a successor has replaced it: a
client still mapping it then goes back to requests instead of reading frozen memory.

Its name derives from the configured endpoint, so a restart finds the segment a killed daemon
left (no process holds its lock any more) and replaces it; a name whose lock a live daemon holds
is skipped for the next (`-1`, `-2`, ...). Each region with passive ranges gets its own
page-aligned part of the file as an mmap (`Region(..., memory=segment)`); local clients map the
whole file (`hello` "shm").

Nothing here stops a daemon from starting: a directory that cannot hold the segment, or a full
one, is logged once and the regions fall back to private memory (requests only).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import logging
import mmap
import os
import time
import weakref
from pathlib import Path
from typing import Any

log = logging.getLogger("vdevd.shm")

#: a segment this old with its lock free is stale whatever its name (`_sweep`)
STALE_AGE_S = 10.0
#: byte 0 of the file while its daemon serves it
LIVE = 1
#: names tried after the endpoint's own (`-1`, `-2`, ...) while live daemons hold them
MAX_NAMES = 64
_GRAIN = mmap.ALLOCATIONGRANULARITY  # an mmap's offset is a multiple of it
_OPEN = os.O_RDWR | os.O_CLOEXEC | os.O_NOFOLLOW


def segment_name(key: str) -> str:
    """The file name of the segment of a daemon whose configured endpoint is `key`: the user's
    id (two users never share a name) and a digest of the endpoint."""
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    return f"vdevd-{os.getuid()}-{digest}"


class Segment:
    """A claimed segment file: `allocate` hands out page-aligned parts of it as mmaps; `close`
    (also run at exit, or when the segment is collected) removes the file."""

    def __init__(self, path: Path, fd: int) -> None:
        self.path = path
        self.size = _GRAIN  # the header page; the regions follow
        os.ftruncate(fd, self.size)
        os.pwrite(fd, bytes([LIVE]), 0)
        self.ident = _ident(fd)
        self._fd = fd
        self._full = False
        self._release = weakref.finalize(self, _remove, str(path), fd, self.ident)

    @classmethod
    def create(cls, directory: str | os.PathLike[str], key: str) -> Segment | None:
        """The segment of the daemon at endpoint `key` in `directory`, a stale one replaced; None
        (logged) when the directory cannot hold one."""
        base = segment_name(key)
        try:
            _sweep(Path(directory))
            for n in range(MAX_NAMES):
                path = Path(directory) / (base if n == 0 else f"{base}-{n}")
                fd = _claim(path)
                if fd is not None:
                    try:
                        return cls(path, fd)
                    except OSError:
                        _remove(str(path), fd, _ident(fd))
                        raise
        except OSError as exc:
            log.warning("no shared memory for local clients (%s): %s", directory,
                        exc.strerror or exc)
            return None
        log.warning("no shared memory for local clients: %d segments named %s* are in use",
                    MAX_NAMES, Path(directory) / base)
        return None

    def allocate(self, size: int) -> tuple[mmap.mmap, int] | None:
        """`size` bytes of the segment, zeroed: (their mapping, their offset in the file); None
        (logged once) when the file cannot grow, e.g. a full tmpfs."""
        if self._full or not self._release.alive:
            return None
        offset = self.size
        end = offset + -(-size // _GRAIN) * _GRAIN
        try:
            os.ftruncate(self._fd, end)
            _reserve(self._fd, offset, end - offset)
            memory = mmap.mmap(self._fd, size, offset=offset)
        except OSError as exc:
            self._full = True
            log.warning("shared memory %s cannot grow to %d bytes (%s): further regions are "
                        "served by requests only", self.path, end, exc.strerror or exc)
            with contextlib.suppress(OSError):
                os.ftruncate(self._fd, offset)
            return None
        self.size = end
        return memory, offset

    def describe(self) -> dict[str, Any]:
        """What a local client needs to map the file and know it is this one (`hello` "shm")."""
        return {"path": str(self.path), "size": self.size, "dev": self.ident[0],
                "ino": self.ident[1]}

    def close(self) -> None:
        """Mark the file gone, remove it (if it is still this segment's) and release its lock.
        The mappings stay valid in this process: the cards' views of them keep working."""
        self._release()


def _claim(path: Path) -> int | None:
    """A new, locked, empty file at `path`, replacing a stale one (its lock free); None when a
    live daemon holds it or it is not this user's. OSError when the directory is unusable."""
    for _ in range(2):
        try:
            fd = os.open(path, _OPEN | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:
            if not _remove_stale(path):
                return None
            continue
        try:
            os.fchmod(fd, 0o600)  # exactly: a umask may have taken the owner's bits
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            return None  # another starter took and locked it between our create and lock
        return fd
    return None


def _sweep(directory: Path) -> None:
    """Remove this user's stale segments of other names (daemons killed on other endpoints). A
    file newer than STALE_AGE_S is left alone: its daemon may be between creating it and taking
    its lock."""
    prefix = segment_name("").rsplit("-", 1)[0] + "-"
    with os.scandir(directory) as entries:
        names = [e.name for e in entries if e.name.startswith(prefix)]
    for name in names:
        _remove_stale(directory / name, min_age_s=STALE_AGE_S)


def _remove_stale(path: Path, min_age_s: float = 0.0) -> bool:
    """Unlink the segment at `path` when no live process holds its lock (a killed daemon's)
    and it is at least `min_age_s` old; False when one does, or when it is not ours to open."""
    try:
        fd = os.open(path, _OPEN)
    except FileNotFoundError:
        return True  # gone meanwhile: try to create it again
    except OSError:
        return False  # another user's, or not a regular file: leave it alone
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        st, now = os.fstat(fd), os.stat(path, follow_symlinks=False)
        if st.st_uid != os.getuid() or (st.st_dev, st.st_ino) != (now.st_dev, now.st_ino):
            return False
        if time.time() - st.st_mtime < min_age_s:
            return False
        log.info("removing the stale shared memory %s (its daemon is gone)", path)
        if st.st_size:
            os.pwrite(fd, b"\0", 0)  # its clients, if any, go back to requests
        os.unlink(path)
        return True
    except FileNotFoundError:
        return True
    except BlockingIOError:
        return False
    finally:
        os.close(fd)


def _reserve(fd: int, offset: int, size: int) -> None:
    """Reserve the pages now, so that a full tmpfs is an error here and not a SIGBUS when a
    card first writes them (a file system without fallocate is left sparse)."""
    try:
        os.posix_fallocate(fd, offset, size)
    except OSError as exc:
        if exc.errno not in (errno.EOPNOTSUPP, errno.EINVAL):
            raise


def _ident(fd: int) -> tuple[int, int]:
    st = os.fstat(fd)
    return st.st_dev, st.st_ino


def _remove(path: str, fd: int, ident: tuple[int, int]) -> None:
    """Mark the file of `fd` gone, unlink `path` if it is still that file (`ident`), then close
    `fd` (its lock goes)."""
    with contextlib.suppress(OSError):
        os.pwrite(fd, b"\0", 0)
    try:
        st = os.stat(path, follow_symlinks=False)
        if (st.st_dev, st.st_ino) == ident:
            os.unlink(path)
    except OSError:
        pass
    with contextlib.suppress(OSError):
        os.close(fd)
