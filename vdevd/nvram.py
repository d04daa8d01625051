"""Non-volatile memory in the state directory (DESIGN.md "Non-volatile memory").

Each card's flash image is one msgpack file, written atomically: temporary file, fsync, rename,
fsync of the directory. A crash or kill at any moment leaves either the old or the new image.
"""

from __future__ import annotations

import logging
import os
import tempfile
from pathlib import Path
from typing import Any

import msgpack

log = logging.getLogger("vdevd.nvram")


class NvramStore:
    """The flash images of a rack's cards, one file per card name."""

    def __init__(self, state_dir: str | os.PathLike[str]) -> None:
        self.dir = Path(state_dir)

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

    def load(self, card: str) -> dict[str, Any] | None:
        """The saved image, or None when the card never saved one or its image is unreadable:
        the card then starts from its power-on defaults, as a real card does after a flash
        checksum error. An unreadable image is kept beside, as `<card>.nvram.corrupt`, and
        temporary files left by a save that was killed are removed."""
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
        if isinstance(image, dict):
            return image
        kept = path.with_name(path.name + ".corrupt")
        os.replace(path, kept)
        log.warning("%s: unreadable flash image (%s); %s starts from its defaults, the image is "
                    "kept as %s", path, image if isinstance(image, Exception) else "not a map",
                    card, kept.name)
        return None
