"""The engineering digests of the manuals (`shared/spec/<card>.md`, beside the repository
checkout): the card tests that check a command table against its digest read them here."""

from __future__ import annotations

from pathlib import Path

import pytest

#: the `shared` folder beside the repository checkout holds the digests
SPEC = Path(__file__).resolve().parents[2].parent / "shared" / "spec"


def digest_text(name: str) -> str:
    """The text of `spec/<name>.md`; the test is skipped, saying where it looked, if absent."""
    path = SPEC / f"{name}.md"
    if not path.is_file():
        pytest.skip(f"the digest spec/{name}.md is not beside this checkout ({path})")
    return path.read_text(encoding="utf-8")
