"""Every function of the APS API that the spec names is in vdevclient.aps, and every one is
called by some test of the card (issue 19: "every API function at least once")
[spec adlink.md §4]."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from vdevclient import aps

SPEC = Path(__file__).resolve().parents[3] / "shared" / "spec" / "adlink.md"
TESTS = Path(__file__).resolve().parent
#: names the spec mentions that are not functions, or that it says the library must not have
NOT_FUNCTIONS = {
    "APS_Define",  # the header
    "APS_pt_pause", "APS_pt_resume",  # Q14: "no invented names in the client library"
}


def spec_functions() -> set[str]:
    """The APS_ names of the spec, with the `(_f)`, `_v`, `_all` variants its tables fold."""
    text = SPEC.read_text()
    names: set[str] = set()
    for m in re.finditer(r"`(APS_\w+?)(\(_f\))?`(?:,\s*`_v`,\s*`_all`)?", text):
        base = m.group(1)
        names.add(base)
        if m.group(2):
            names.add(base + "_f")
        if m.group(0).endswith("`_all`"):
            names |= {base + "_v", base + "_all"}
    for m in re.finditer(r"\bAPS_\w+", text):
        names.add(m.group(0))
    return {n for n in names if not n.endswith("_") and n not in NOT_FUNCTIONS}


@pytest.mark.skipif(not SPEC.exists(), reason="the spec digest is not beside the checkout")
def test_every_function_the_spec_names_is_in_the_library() -> None:
    missing = sorted(n for n in spec_functions() if not callable(getattr(aps, n, None)))
    assert missing == []


def test_every_library_function_is_called_by_a_test() -> None:
    calls = "".join(p.read_text() for p in TESTS.glob("test_aps*.py") if p.name != Path(__file__).name)
    exported = sorted(n for n in dir(aps) if n.startswith("APS_") and callable(getattr(aps, n)))
    untested = [n for n in exported if not re.search(rf"\b{n}\b", calls)]  # called, or handed to f64/i32
    assert untested == []
