"""Non-volatile memory in the state directory (DESIGN.md "Non-volatile memory").

Each card's flash image is one msgpack file, written atomically: temporary file, fsync, rename,
fsync of the directory. A crash or kill at any moment leaves either the old or the new image.

An image that cannot be read, or that its card's check refuses (`load(card, check)`: the shape
and every value checked as strictly as the commands that set them; vdevd/nvcheck.py), never
stops the daemon: it is kept beside as `<card>.nvram.corrupt`, logged, and the card starts from
its defaults (issue 22 §4).
"""

from __future__ import annotations

import logging
import os
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgpack

log = logging.getLogger("vdevd.nvram")


class NvramStore:
    """The flash images of a rack's cards, one file per card name."""

    def __init__(self, state_dir: str | os.PathLike[str]) -> None:
        self.dir = Path(state_dir)
        self.saves: dict[str, int] = {}  # images written, by card (the metrics endpoint)

    def path(self, card: str) -> Path:
        return self.dir / f"{card}.nvram"

    def save(self, card: str, image: dict[str, Any]) -> None:
        self.dir.mkdir(parents=True, exist_ok=True)
        data = msgpack.packb(image, use_bin_type=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{card}.", dir=self.dir)
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, self.path(card))
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        dir_fd = os.open(self.dir, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
        self.saves[card] = self.saves.get(card, 0) + 1

    def load(self, card: str,
             check: Callable[[dict[str, Any]], object] | None = None) -> dict[str, Any] | None:
        """The saved image, or None when the card never saved one or its image is unreadable
        or refused by `check` (which raises ValueError or TypeError naming what is wrong): the
        card then starts from its power-on defaults, as a real card does after a flash checksum
        error. Such an image is kept beside, as `<card>.nvram.corrupt`, and temporary files
        left by a save that was killed are removed."""
        for stale in self.dir.glob(f".{card}.*"):
            stale.unlink(missing_ok=True)
        path = self.path(card)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return None
        try:
            image = msgpack.unpackb(data, raw=False, strict_map_key=False)
        except Exception as exc:  # msgpack raises several unrelated types for bad input
            image = exc
        if not isinstance(image, dict):
            self.quarantine(card, "unreadable",
                            str(image) if isinstance(image, Exception) else "not a map")
            return None
        if check is not None:
            try:
                check(image)
            except (ValueError, TypeError) as exc:
                self.quarantine(card, "invalid", str(exc))
                return None
        return image

    def quarantine(self, card: str, kind: str, reason: str) -> None:
        """The card's image is no good (`kind`: unreadable, invalid; `reason`): kept as
        `<card>.nvram.corrupt` (replacing an older one), logged; the card starts from its
        defaults."""
        path = self.path(card)
        kept = path.with_name(path.name + ".corrupt")
        try:
            os.replace(path, kept)
        except FileNotFoundError:
            return
        log.warning("%s: %s flash image (%s); %s starts from its defaults, the image is kept "
                    "as %s", path, kind, reason, card, kept.name)


#: seconds a writer waits for more images of a burst before it writes the last
COALESCE_S = 0.05


class NvramWriter:
    """Saves a card's images on a thread of its own, the last one submitted winning (a
    card's flash or battery RAM written off the event loop)."""

    def __init__(self, store: NvramStore, card: str, coalesce_s: float = COALESCE_S) -> None:
        self.store, self.card, self.coalesce_s = store, card, coalesce_s
        self._cond = threading.Condition()
        self._pending: dict[str, Any] | None = None
        self._writing = False
        self._closed = False
        self._hurry = False  # a flush waits: write without coalescing
        self._thread: threading.Thread | None = None
        self.saved = 0  # images written (tests, stats)

    def submit(self, image: dict[str, Any]) -> None:
        """Save `image` soon; returns at once. Once closed (the daemon stopping), the image is
        dropped with a warning: a tick must not raise for it."""
        with self._cond:
            if self._closed:
                log.warning("%s: non-volatile state changed after the writer closed: not saved",
                            self.card)
                return
            self._pending = image
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, daemon=True,
                                                name=f"vdevd-nvram-{self.card}")
                self._thread.start()
            self._cond.notify_all()

    def _run(self) -> None:
        cond = self._cond
        while True:
            with cond:
                while self._pending is None and not self._closed:
                    cond.wait()
                if self._pending is None:
                    return
                deadline = time.monotonic() + self.coalesce_s
                while not (self._closed or self._hurry):  # a burst of downloads: one write
                    left = deadline - time.monotonic()
                    if left <= 0:
                        break
                    cond.wait(left)
                image, self._pending, self._writing = self._pending, None, True
            try:
                self.store.save(self.card, image)
            except Exception:  # a full or read-only disk must not stop the card
                log.exception("%s: saving its non-volatile state", self.card)
            with cond:
                self._writing = False
                self.saved += 1
                cond.notify_all()

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every image submitted is written; False on timeout."""
        with self._cond:
            if self._thread is None:
                return True
            self._hurry = True
            self._cond.notify_all()
            done = self._cond.wait_for(lambda: self._pending is None and not self._writing,
                                       timeout)
            self._hurry = False
            return done

    def close(self, timeout: float | None = 10.0) -> None:
        """Write what is pending and end the thread (the daemon stops)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
            thread = self._thread
        if thread is not None:
            thread.join(timeout)
