"""Wire protocol v1, sans-I/O: decode and validate requests, encode replies (proto/PROTOCOL.md).

Nothing here touches a socket: `decode_request(bytes) -> Request` raises `VdevError` carrying the
error code (and the request id when one could be read); `encode_ok`/`encode_error` build reply
bytes. The server only moves these bytes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import msgpack

from vdevd.errors import ErrorCode, VdevError

VERSION = 1
#: The largest request or reply body; larger requests get a `too_large` error reply.
MAX_MESSAGE = 1 << 20
#: Above this the socket drops the message (and the peer) unread (ZMQ_MAXMSGSIZE).
HARD_MAX_MESSAGE = 4 * MAX_MESSAGE
#: The longest wait or step a request may ask for, in simulated ns (one day).
MAX_WAIT_NS = 86_400 * 1_000_000_000

CAPABILITIES = ("read", "write", "rep", "batch", "batch.compact", "wait.irq", "wait.value", "sim",
                "control", "stats", "sync", "shm", "heartbeat", "scope", "snapshot")



@dataclass(frozen=True, slots=True)
class Field:
    """A field's allowed msgpack types (exact Python types: a bool is not an int) and whether
    it is required."""

    types: frozenset[type]
    required: bool = True


def _f(types: type | tuple[type, ...], required: bool = True) -> Field:
    return Field(frozenset(types if isinstance(types, tuple) else (types,)), required)


_INT = int
_STR = str
_BYTES = (bytes, bytearray)
_MAP = dict
_LIST = list

#: op -> the fields it takes beside `id`, `op` and `v` (proto/PROTOCOL.md, "Operations").
SCHEMA: dict[str, dict[str, Field]] = {
    "hello": {"client": _f(_STR, False)},
    "read": {"card": _f(_STR), "region": _f(_STR), "offset": _f(_INT), "size": _f(_INT),
             "rep": _f(bool, False)},
    "write": {"card": _f(_STR), "region": _f(_STR), "offset": _f(_INT), "data": _f(_BYTES),
              "rep": _f(bool, False)},
    "batch": {"ops": _f(_LIST)},
    "wait": {
        "card": _f(_STR),
        "on": _f(_STR),
        "timeout_ns": _f(_INT),
        "line": _f(_STR, False),
        "after_seq": _f(_INT, False),
        "region": _f(_STR, False),
        "offset": _f(_INT, False),
        "size": _f(_INT, False),
        "mask": _f(_INT, False),
        "value": _f(_INT, False),
        "cmp": _f(_STR, False),
    },
    "sim": {
        "action": _f(_STR),
        "ns": _f(_INT, False),
        "ticks": _f(_INT, False),
        "seconds": _f((int, float), False),
        "card": _f(_STR, False),
    },
    "control": {
        "card": _f(_STR),
        "action": _f(_STR),
        "params": _f(_MAP, False),
        "at_ns": _f(_INT, False),
        "after_ns": _f(_INT, False),
    },
    "stats": {},
    "sync": {"card": _f(_STR)},
    "scope": {
        "card": _f(_STR),
        "action": _f(_STR),
        "axes": _f(_LIST, False),
        "signals": _f(_LIST, False),
        "every": _f(_INT, False),
        "samples": _f(_INT, False),
        "seconds": _f((int, float), False),
        "pre": _f(_INT, False),
        "trigger": _f(_MAP, False),
        "start": _f(_INT, False),
        "count": _f(_INT, False),
    },
    "snapshot": {"action": _f(_STR), "offset": _f(_INT, False), "size": _f(_INT, False),
                 "data": _f(_BYTES, False)},
}
_META = ("id", "op", "v")
_REQUIRED = {op: tuple(k for k, f in fields.items() if f.required) for op, fields in SCHEMA.items()}

#: ops allowed inside a batch
BATCHABLE = frozenset({"read", "write", "wait", "control"})


@dataclass(slots=True)
class Request:
    """A validated request: `args` holds the op's fields, already type-checked; `local`, set by
    the server, says the client is on this machine (a `hello` then announces the shared memory);
    `client`, set by the server, is who sent it (the ROUTER's peer identity), which the limits
    per client count by."""

    id: Any
    op: str
    args: dict[str, Any]
    local: bool = False
    client: bytes = b""


_unpack = msgpack.unpackb  # str keys only (strict_map_key), str as str, arrays as lists


def validate(op: Any, fields: Mapping[Any, Any], req_id: Any = None) -> Request:
    """Check one operation's fields against SCHEMA; raise VdevError(MALFORMED/UNKNOWN_OP)."""
    schema = SCHEMA.get(op) if isinstance(op, str) else None
    if schema is None:
        if not isinstance(op, str):
            raise VdevError(ErrorCode.MALFORMED, "field 'op' must be a string")
        raise VdevError(ErrorCode.UNKNOWN_OP, f"unknown op {op!r} (ops: {', '.join(SCHEMA)})")
    args: dict[str, Any] = {}
    for name, value in fields.items():  # the fields given: fewer than the schema's, usually
        spec = schema.get(name)
        if spec is None:
            if name in _META:
                continue
            raise VdevError(ErrorCode.MALFORMED, f"{op}: unknown field {name!r}")
        if value is None:
            continue
        if type(value) not in spec.types:
            raise VdevError(
                ErrorCode.MALFORMED,
                f"{op}: field {name!r} has the wrong type ({type(value).__name__})",
            )
        args[name] = value
    for name in _REQUIRED[op]:
        if name not in args:
            raise VdevError(ErrorCode.MALFORMED, f"{op}: missing field {name!r}")
    return Request(req_id, op, args)


def decode_request(payload: bytes) -> Request:
    """Decode one request body. Errors carry `.req_id` when the id could be read."""
    return request_from(unpack_message(payload))


def unpack_message(payload: bytes) -> Any:
    """The msgpack object of a request body, within the maximum size."""
    if len(payload) > MAX_MESSAGE:
        raise _with_id(VdevError(ErrorCode.TOO_LARGE, f"message of {len(payload)} bytes "
                                 f"exceeds the maximum of {MAX_MESSAGE}"), None)
    try:
        return _unpack(payload)
    except Exception as exc:  # msgpack raises several unrelated types for bad input
        raise _with_id(VdevError(ErrorCode.MALFORMED, f"not msgpack: {_unpack_failure(exc, payload)}"),
                       None) from None


def _unpack_failure(exc: Exception, payload: bytes) -> str:
    """What was wrong with a body msgpack could not unpack, never empty (msgpack's FormatError
    and StackError carry no message)."""
    reason = str(exc) or {"FormatError": "a byte that begins no msgpack object",
                          "StackError": "nested too deep"}.get(type(exc).__name__,
                                                               type(exc).__name__)
    if not payload:
        return f"{reason} (the body is empty)"
    return f"{reason} (the body of {len(payload)} bytes begins {payload[:8].hex(' ')})"


def read_fields(msg: Any) -> tuple[Any, str, str, int, int] | None:
    """(id, card, region, offset, size) of a well-formed v1 `read`, else None.

    The hot path of every register read: the same checks as `request_from` for this one shape,
    in a few operations. Anything else (including a malformed read) takes the general path.
    """
    try:
        if msg["op"] != "read" or len(msg) != 6:
            return None
        req_id, card, region, offset, size = (
            msg["id"], msg["card"], msg["region"], msg["offset"], msg["size"])
    except (KeyError, TypeError, IndexError):
        return None
    if (type(card) is str and type(region) is str and type(offset) is int
            and type(size) is int and type(req_id) not in _CONTAINERS):
        return req_id, card, region, offset, size
    return None


_CONTAINERS = (dict, list)


def request_from(msg: Any) -> Request:
    """Validate an unpacked request (see `decode_request`)."""
    if type(msg) is dict and len(msg) == 3 and msg.get("op") == "batch" and "id" in msg:
        ops, req_id = msg.get("ops"), msg["id"]  # {id, op, ops}: what clients send for a batch
        if type(ops) is list and type(req_id) not in _CONTAINERS:
            try:
                return Request(req_id, "batch", {"ops": _batch_ops(ops)})
            except VdevError as exc:
                raise _with_id(exc, req_id) from None
    if not isinstance(msg, dict):
        raise _with_id(VdevError(ErrorCode.MALFORMED, "a request is a msgpack map"), None)
    req_id = msg.get("id")
    if isinstance(req_id, (dict, list)):
        raise _with_id(VdevError(ErrorCode.MALFORMED, "field 'id' must be a scalar"), None)
    v = msg.get("v", VERSION)
    if v != VERSION or isinstance(v, bool):
        raise _with_id(
            VdevError(ErrorCode.BAD_VERSION, f"protocol version {v!r} not supported "
                      f"(this server speaks {VERSION})"), req_id)
    try:
        req = validate(msg.get("op"), msg, req_id)
        if req.op == "batch":
            req.args["ops"] = _batch_ops(req.args["ops"])
    except VdevError as exc:
        raise _with_id(exc, req_id) from None
    return req


#: A batch's plain read or write, ready to run: [kind, card, region, offset, size or data], kind
#: "r" read, "w" write, "R" repeated read, "W" repeated write (PROTOCOL.md "Compact accesses").
#: A compact op arrives as this list; the map form of a plain access becomes this tuple.
Access = tuple[str, str, str, int, Any] | list[Any]
#: kind -> the type of its last field: a size (int) or data (bytes)
_ACCESS_LAST: dict[str, type] = {"r": int, "w": bytes, "R": int, "W": bytes}


def _batch_ops(ops: list[Any]) -> list[Request | Access]:
    """A batch's ops, validated. A plain read or write, in its compact form or as the usual map
    ({op, card, region, offset, size|data[, rep]} with the right types), is checked here in a
    few operations and becomes an `Access`; anything else goes through `validate`, which
    accepts it or names what is wrong."""
    out: list[Request | Access] = []
    append = out.append
    for i, op in enumerate(ops):
        kind = type(op)
        if kind is list:
            if len(op) == 5:
                name, card, region, offset, last = op
                if type(name) is str and type(last) is _ACCESS_LAST.get(name) \
                        and type(card) is str and type(region) is str and type(offset) is int:
                    append(op)
                    continue
            raise VdevError(ErrorCode.MALFORMED, f"batch op {i}: a compact access is "
                            "[r|w|R|W, card, region, offset, size|data]")
        if kind is dict:
            name = op.get("op")
            if type(name) is str and name in _PLAIN_KEYS:
                keys, keys_rep, last, last_type = _PLAIN_KEYS[name]
                found = op.keys()
                if found == keys:
                    rep: bool | None = False
                elif found == keys_rep and type(op["rep"]) is bool:
                    rep = op["rep"]
                else:
                    rep = None
                if rep is not None \
                        and type(op[last]) is last_type and type(op["card"]) is str \
                        and type(op["region"]) is str and type(op["offset"]) is int:
                    code = name[0].upper() if rep else name[0]
                    append((code, op["card"], op["region"], op["offset"], op[last]))
                    continue
            elif name == "wait" and op.keys() == _WAIT_VALUE_KEYS and _wait_value_typed(op):
                # a wait on a value with every field given (what clients send to poll a
                # register): what `validate` accepts, in a few operations
                args = dict(op)
                del args["op"]
                append(Request(None, "wait", args))
                continue
        append(_validate_batch_op(i, op))
    return out


#: a wait on a value with all its fields: the fields and their one type each (SCHEMA's)
_WAIT_VALUE_TYPES = tuple((k, t) for k, t in (
    ("card", str), ("on", str), ("timeout_ns", int), ("region", str), ("offset", int),
    ("size", int), ("mask", int), ("value", int), ("cmp", str)))
_WAIT_VALUE_KEYS = frozenset(["op", *(k for k, _ in _WAIT_VALUE_TYPES)])
assert all(SCHEMA["wait"][k].types == {t} for k, t in _WAIT_VALUE_TYPES)


def _wait_value_typed(op: dict[str, Any]) -> bool:
    """Every field of a wait on a value (`_WAIT_VALUE_TYPES`) has its type."""
    return (type(op["card"]) is str and type(op["on"]) is str and type(op["timeout_ns"]) is int
            and type(op["region"]) is str and type(op["offset"]) is int
            and type(op["size"]) is int and type(op["mask"]) is int
            and type(op["value"]) is int and type(op["cmp"]) is str)


def _validate_batch_op(index: int, op: Any) -> Request:
    if not isinstance(op, dict):
        raise VdevError(ErrorCode.MALFORMED, f"batch op {index}: not a map")
    name = op.get("op")
    if name not in BATCHABLE:
        raise VdevError(ErrorCode.MALFORMED, f"batch op {index}: {name!r} cannot be batched "
                        f"(batchable: {', '.join(sorted(BATCHABLE))})")
    try:
        return validate(name, op)
    except VdevError as exc:
        raise VdevError(exc.code, f"batch op {index}: {exc.message}") from None


#: the key sets of a plain batch access without and with `rep`, its last field and that
#: field's type (as msgpack gives it)
_PLAIN_KEYS: dict[str, tuple[frozenset[str], frozenset[str], str, type]] = {
    "read": (frozenset({"op", "card", "region", "offset", "size"}),
             frozenset({"op", "card", "region", "offset", "size", "rep"}), "size", int),
    "write": (frozenset({"op", "card", "region", "offset", "data"}),
              frozenset({"op", "card", "region", "offset", "data", "rep"}), "data", bytes),
}


def _with_id(exc: VdevError, req_id: Any) -> VdevError:
    exc.req_id = req_id  # type: ignore[attr-defined]
    return exc


def encode_ok(req_id: Any, result: Any, pack: Callable[[Any], bytes] | None = None) -> bytes:
    """An ok reply. `pack`: a reused `msgpack.Packer(use_bin_type=True).pack`, which saves
    creating a packer per reply on the hot path."""
    body = {"id": req_id, "ok": result}
    return pack(body) if pack is not None else msgpack.packb(body, use_bin_type=True)


def encode_error(req_id: Any, code: str, message: str) -> bytes:
    return msgpack.packb(
        {"id": req_id, "error": {"code": str(code), "message": message}}, use_bin_type=True
    )


def encode_event(event: Mapping[str, Any]) -> bytes:
    return msgpack.packb(dict(event), use_bin_type=True)
