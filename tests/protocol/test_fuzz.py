"""Hypothesis fuzz of the request decoder through a live server: every message gets exactly one
reply, ok or a known error code, and the daemon keeps serving."""

from __future__ import annotations

from typing import Any

import msgpack
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import RawClient
from vdevd.errors import ErrorCode
from vdevd.protocol import SCHEMA

CODES = {c.value for c in ErrorCode}
scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**40), 2**40), st.text(max_size=8),
    st.binary(max_size=16), st.floats(allow_nan=False),
)
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(st.text(max_size=6), inner, max_size=3), max_leaves=8)
field_names = st.sampled_from(sorted({f for s in SCHEMA.values() for f in s}) + ["id", "v", "zz"])
requests = st.fixed_dictionaries(
    {"op": st.sampled_from([*SCHEMA, "bogus"])},
    optional={"id": st.integers(0, 1000)},
).flatmap(lambda base: st.dictionaries(field_names, values, max_size=6).map(
    lambda extra: {**extra, **base}))
FUZZ = settings(derandomize=True, max_examples=300, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])
# sim steps are bounded so a fuzzed lockstep step cannot run for long
SAFE = {"timeout_ns", "ns", "ticks", "seconds", "after_ns", "at_ns"}


def _bounded(req: dict[str, Any]) -> dict[str, Any]:
    for key in SAFE & req.keys():
        if isinstance(req[key], (int, float)) and not isinstance(req[key], bool):
            req[key] = abs(req[key]) % 1000
    return req


def _check(reply: dict[str, Any]) -> None:
    """One well-formed reply; an error names what the client got wrong, never a daemon bug."""
    assert set(reply) in ({"id", "ok"}, {"id", "error"})
    if "error" in reply:
        assert reply["error"]["code"] in CODES
        assert reply["error"]["code"] != "internal", reply["error"]["message"]
        assert isinstance(reply["error"]["message"], str)


@FUZZ
@given(body=st.binary(max_size=64))
def test_random_bytes_get_one_reply_each(raw: RawClient, body: bytes) -> None:
    _check(raw.send_raw(body))


@FUZZ
@given(req=requests)
def test_random_requests_get_one_reply_each(raw: RawClient, req: dict[str, Any]) -> None:
    _check(raw.send_raw(msgpack.packb(_bounded(req), use_bin_type=True)))
    alive = raw.call(op="sim", action="now")
    assert "ok" in alive
