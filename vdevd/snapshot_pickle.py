"""How a rack snapshot pickles and unpickles (vdevd/snapshot.py is the file around it).

`SnapshotPickler` pickles the scheduler and the cards; what is the daemon's I/O becomes a
persistent id: the rack itself (the cards' interrupt sink), the event sink, the non-volatile
store and its writers, the shared-memory segment (a shared region's bytes are saved and placed in
the new segment at load), the compiled kernels, loggers, locks; the event loop's objects,
sockets, threads and the cards' listeners are dropped. Buffers seen through views (numpy arrays
and memoryviews onto a region's memory or onto another array) stay views of one buffer. A
function made at run time (a lambda, a closure) is saved as where its code is in vdevd and what
it closes over; its code comes from the installed vdevd at load, never from the file.

`SnapshotUnpickler` is the Python unpickler with an allow-list: `find_class` finds only vdevd's
(and its register maps') classes and functions, but those of its I/O modules, and a short list
of containers and numpy reconstructors; REDUCE calls only those reconstructors, vdevd enums and
tuples and the function rebuilder; NEWOBJ builds only classes so found; BUILD never sets the
state of a class or function; INST, OBJ and the extension registry are refused. Anything else
is a `bad_snapshot` error: a snapshot never runs code of its own.
"""

from __future__ import annotations

import enum
import io
import logging
import mmap
import pickle
import sys
import threading
import types
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from vdevd.devices.options import CardOptions
from vdevd.errors import ErrorCode, VdevError
from vdevd.nvram import NvramStore, NvramWriter
from vdevd.shm import Segment

if TYPE_CHECKING:
    from vdevd.rack import Rack

PROTOCOL = 5


def bad(message: str) -> VdevError:
    """A snapshot that cannot be loaded (or saved): `bad_snapshot`, naming why."""
    return VdevError(ErrorCode.BAD_SNAPSHOT, message)


#: the types pickled as they are, asked about first (most of the graph)
_PLAIN = frozenset({int, float, str, bytes, bool, type(None), tuple, list, dict, set, frozenset,
                    bytearray, complex})
#: what belongs to the daemon's I/O and is not part of a card's state: restored as None
_DROPPED: tuple[type, ...] = (threading.Thread, threading.Event, threading.Condition)
_LOCKS = (type(threading.Lock()), type(threading.RLock()))


def _address(buf: Any) -> int:
    """Where a buffer's memory starts."""
    return int(np.frombuffer(buf, np.uint8).__array_interface__["data"][0]) if len(
        memoryview(buf)) else 0


class SnapshotPickler(pickle.Pickler):
    """Pickles a rack's cards; the daemon's I/O becomes persistent ids (module docstring)."""

    def __init__(self, file: io.BytesIO, rack: Rack) -> None:
        super().__init__(file, protocol=PROTOCOL)
        self.rack = rack
        self._shared: dict[int, int] = {}  # id(mmap) -> its index in the snapshot
        self._keep: list[Any] = []  # objects whose id is a key above stay alive
        self._code_indexes: dict[str, CodeIndex] = {}
        self._globals: dict[str, dict[int, tuple[str, Any]]] = {}
        self._compiled = _compiled_kernels()

    def persistent_id(self, obj: Any) -> Any:  # noqa: C901 - one case per kind of I/O
        t = type(obj)
        if t in _PLAIN:
            return None
        if obj is self.rack:
            return ("rack",)
        if obj is self.rack.sink:
            return ("sink",)
        compiled = self._compiled.get(id(obj))
        if compiled is not None:
            return ("compiled", *compiled)
        if isinstance(obj, np.ndarray):
            return self._array(obj)
        if t is types.MethodType or t is types.BuiltinMethodType and not isinstance(
                obj.__self__, types.ModuleType) and obj.__self__ is not None:
            owner = obj.__self__
            if isinstance(owner, _DROPPED) or _is_io(owner):
                return ("dropped",)  # a method of the event loop (a timer's callback)
            return ("method", owner, obj.__name__)
        if t is mmap.mmap:
            return self._mmap(obj)
        if t is memoryview:
            base = obj.obj
            if not obj.contiguous or obj.ndim != 1 or obj.format not in ("B", "b", "c"):
                raise pickle.PicklingError(f"a memoryview of format {obj.format!r}, "
                                           f"{obj.ndim} dimensions")
            return ("memview", base, _address(obj) - _address(base), obj.nbytes, obj.readonly)
        if t is types.MappingProxyType:
            return ("proxy", dict(obj))
        if isinstance(obj, NvramStore):
            return ("nvram",)
        if isinstance(obj, NvramWriter):
            return ("writer", obj.card)
        if isinstance(obj, Segment):
            return ("memory",)
        if isinstance(obj, logging.Logger):
            return ("logger", obj.name)
        if t in _LOCKS:
            return ("lock", t is _LOCKS[1])
        if isinstance(obj, _DROPPED) or _is_io(obj):
            return ("dropped",)
        return None

    def reducer_override(self, obj: Any) -> Any:
        """A function made at run time (a lambda, a closure): by where its code is in vdevd
        and what it closes over (`_make_function`); never its code."""
        if type(obj) is not types.FunctionType or "<" not in obj.__qualname__:
            return NotImplemented
        module = obj.__module__
        key = self._codes(module).keys.get(id(obj.__code__))
        if key is None:
            found = self._module_functions(module).get(id(obj))
            if found is not None:
                return _module_object, (module, *found)
            raise pickle.PicklingError(f"function {obj.__qualname__} of {module} not found")
        cells = tuple(c.cell_contents for c in obj.__closure__ or ())
        return _make_function, (module, *key, obj.__defaults__, obj.__kwdefaults__, cells)

    def _codes(self, module: str) -> CodeIndex:
        index = self._code_indexes.get(module)
        if index is None:
            index = self._code_indexes[module] = CodeIndex(module)
        return index

    def _module_functions(self, module: str) -> dict[int, tuple[str, Any]]:
        found = self._globals.get(module)
        if found is None:
            found = self._globals[module] = _module_functions(module)
        return found

    def _mmap(self, obj: mmap.mmap) -> tuple[Any, ...]:
        """A shared region's memory: its bytes once, then its index."""
        index = self._shared.get(id(obj))
        if index is not None:
            return ("shm", index, None)
        index = self._shared[id(obj)] = len(self._shared)
        self._keep.append(obj)
        return ("shm", index, bytes(obj))

    @staticmethod
    def _array(a: np.ndarray) -> tuple[Any, ...] | None:
        """An array that is a view: of the buffer (or the array owning the memory) it sees."""
        if a.base is None:
            return None
        root: Any = a
        while isinstance(root, np.ndarray) and root.base is not None:
            root = root.base
        if isinstance(root, memoryview):
            root = root.obj
        if isinstance(root, np.ndarray):
            start = int(root.__array_interface__["data"][0])
        elif isinstance(root, bytes | bytearray | mmap.mmap):
            start = _address(root)
        else:  # memory numpy owns through an object of its own: a copy is the array
            return None
        offset = int(a.__array_interface__["data"][0]) - start
        return ("view", root, offset, a.shape, a.strides, a.dtype)


class CodeIndex:
    """The code objects of a vdevd module, by (qualified name, first line, ordinal): where a
    function made at run time finds its code again in the installed vdevd."""

    def __init__(self, module: str) -> None:
        mod = sys.modules.get(module)
        if mod is None or not (module == "vdevd" or module.startswith("vdevd.")):
            raise bad(f"corrupt: a function of module {module!r}")
        self.codes: dict[tuple[str, int, int], types.CodeType] = {}
        self.keys: dict[int, tuple[str, int, int]] = {}
        seen: set[int] = set()
        for obj in list(vars(mod).values()):
            self._walk_object(obj, module, seen)

    def _walk_object(self, obj: Any, module: str, seen: set[int]) -> None:
        if id(obj) in seen:
            return
        seen.add(id(obj))
        if isinstance(obj, staticmethod | classmethod):
            obj = obj.__func__
        if isinstance(obj, property):
            for f in (obj.fget, obj.fset, obj.fdel):
                if f is not None:
                    self._walk_object(f, module, seen)
            return
        if isinstance(obj, types.FunctionType) and obj.__module__ == module:
            self._walk_code(obj.__code__, seen)
            wrapped = getattr(obj, "__wrapped__", None)
            if wrapped is not None:
                self._walk_object(wrapped, module, seen)
        elif isinstance(obj, type) and obj.__module__ == module:
            for attr in list(vars(obj).values()):
                self._walk_object(attr, module, seen)

    def _walk_code(self, code: types.CodeType, seen: set[int]) -> None:
        if id(code) in seen:
            return
        seen.add(id(code))
        n = 0
        while (code.co_qualname, code.co_firstlineno, n) in self.codes:
            n += 1
        key = (code.co_qualname, code.co_firstlineno, n)
        self.codes[key] = code
        self.keys[id(code)] = key
        for const in code.co_consts:
            if isinstance(const, types.CodeType):
                self._walk_code(const, seen)


def _module_functions(module: str) -> dict[int, tuple[str, Any]]:
    """The functions a vdevd module holds in its globals, directly or in a dict, list or
    tuple there (a table of lambdas): id -> (global name, key or None)."""
    mod = sys.modules.get(module)
    found: dict[int, tuple[str, Any]] = {}
    if mod is None:
        return found
    for name, value in vars(mod).items():
        if isinstance(value, types.FunctionType):
            found.setdefault(id(value), (name, None))
        elif isinstance(value, dict):
            for k, v in value.items():
                if isinstance(v, types.FunctionType) and isinstance(k, str | int):
                    found.setdefault(id(v), (name, k))
        elif isinstance(value, list | tuple):
            for i, v in enumerate(value):
                if isinstance(v, types.FunctionType):
                    found.setdefault(id(v), (name, i))
    return found


def _module_object(module: str, name: str, key: Any) -> Any:
    """A function a vdevd module holds in its globals (`_module_functions`), at load."""
    mod = sys.modules.get(module)
    if mod is None or not module.startswith("vdevd"):
        raise bad(f"corrupt: a function of module {module!r}")
    value = vars(mod).get(name)
    if key is not None:
        try:
            value = value[key]  # type: ignore[index]
        except (KeyError, IndexError, TypeError):
            value = None
    if not isinstance(value, types.FunctionType):
        raise bad(f"corrupt: {module}.{name} holds no function at {key!r}")
    return value


def _make_function(module: str, qualname: str, line: int, n: int, defaults: Any,
                   kwdefaults: Any, cells: tuple[Any, ...],
                   index: CodeIndex | None = None) -> types.FunctionType:
    """A function made at run time, again: its code from the installed vdevd, what it closed
    over from the snapshot."""
    code = (index or CodeIndex(module)).codes.get((qualname, line, n))
    if code is None or len(code.co_freevars) != len(cells):
        raise bad(f"corrupt: no function {qualname} at line {line} of {module}")
    if defaults is not None and not isinstance(defaults, tuple) or (
            kwdefaults is not None and not isinstance(kwdefaults, dict)):
        raise bad(f"corrupt: the defaults of {qualname}")
    mod = sys.modules[module]
    fn = types.FunctionType(code, vars(mod), code.co_name, defaults,
                            tuple(types.CellType(c) for c in cells) or None)
    fn.__kwdefaults__ = kwdefaults
    fn.__qualname__ = qualname
    return fn


def _compiled_kernels() -> dict[int, tuple[str, str, int | None]]:
    """The compiled kernels (numba) vdevd has built, each the result of a cached `*compiled`
    function of a vdevd module: id -> (module, function, index in its tuple or None)."""
    found: dict[int, tuple[str, str, int | None]] = {}
    for module, mod in list(sys.modules.items()):
        if not module.startswith("vdevd.") or mod is None:
            continue
        for name, fn in list(vars(mod).items()):
            if not name.endswith("compiled") or not hasattr(fn, "cache_info") \
                    or not fn.cache_info().currsize:
                continue
            value = fn()
            if isinstance(value, tuple):
                found.update({id(v): (module, name, i) for i, v in enumerate(value)})
            elif value is not None:
                found[id(value)] = (module, name, None)
    return found


def _compiled(module: str, name: str, index: Any) -> Any:
    """A compiled kernel at load (`_compiled_kernels`): the installed vdevd's own."""
    mod = sys.modules.get(module)
    fn = vars(mod).get(name) if mod is not None and module.startswith("vdevd.") else None
    if fn is None or not name.endswith("compiled") or not hasattr(fn, "cache_info"):
        raise bad(f"corrupt: no compiled kernel {module}.{name}")
    value = fn()
    return value[index] if isinstance(index, int) else value


#: vdevd's modules of I/O: their objects held by a card (its listeners and their connections)
#: are dropped at a save, and nothing of them is ever built from a snapshot
_IO_MODULES = frozenset({
    "vdevd.tcp_listener", "vdevd.devices.galil.ethernet", "vdevd.devices.pmac.ethernet_server"})
#: ... and what a snapshot never names either: the daemon's own I/O and files
_NEVER_NAMED = _IO_MODULES | {
    "vdevd.nvram", "vdevd.shm", "vdevd.server", "vdevd.daemon", "vdevd.testing", "vdevd.rack",
    "vdevd.pacing", "vdevd.http_health", "vdevd.prom", "vdevd.cli", "vdevd.pytest_plugin",
    "vdevd.config", "vdevd.card_ports", "vdevd.heartbeat", "vdevd.docs", "vdevd.nvcheck"}


def _is_io(obj: Any) -> bool:
    """An object of the event loop, of a socket, or of a card's listener."""
    module = type(obj).__module__
    return module.startswith(("asyncio", "uvloop", "socket", "_socket", "selectors", "zmq",
                              "concurrent.")) or module in _IO_MODULES



#: the packages whose classes and functions a snapshot names (vdevd and its register maps)
_PACKAGES = ("vdevd", "vdevmaps")
#: what the restricted unpickler finds outside them: (module, name)
_ALLOWED_GLOBALS = {
    ("builtins", "set"), ("builtins", "frozenset"), ("builtins", "bytearray"),
    ("builtins", "complex"), ("builtins", "slice"), ("builtins", "range"),
    ("builtins", "object"), ("builtins", "bytes"), ("builtins", "int"), ("builtins", "float"),
    ("builtins", "str"), ("builtins", "bool"), ("builtins", "list"), ("builtins", "dict"),
    ("builtins", "tuple"),
    ("copyreg", "_reconstructor"),
    ("fractions", "Fraction"),
    ("collections", "deque"), ("collections", "OrderedDict"), ("collections", "defaultdict"),
    ("collections", "Counter"), ("functools", "partial"),
    ("numpy", "ndarray"), ("numpy", "dtype"),
    ("numpy._core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "scalar"),
    ("numpy._core.numeric", "_frombuffer"),
    ("numpy.core.multiarray", "_reconstruct"), ("numpy.core.multiarray", "scalar"),
    ("numpy.core.numeric", "_frombuffer"),
}
#: of those, what may be called to build an object (REDUCE)
_CALLABLE = {("builtins", n) for n in ("set", "frozenset", "bytearray", "complex", "slice",
                                       "range", "bytes", "int", "float", "str", "bool")} | {
    ("copyreg", "_reconstructor"), ("fractions", "Fraction"), ("collections", "deque"),
    ("collections", "OrderedDict"), ("collections", "defaultdict"), ("collections", "Counter"),
    ("functools", "partial"), ("numpy", "dtype"), ("numpy", "ndarray"),
    ("numpy._core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "scalar"),
    ("numpy._core.numeric", "_frombuffer"), ("numpy.core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"), ("numpy.core.numeric", "_frombuffer")}


#: vdevd's own callables a snapshot calls to build what it holds
_OWN_CALLABLES = (CardOptions, _make_function, _module_object)


#: the unpickler written in Python, whose opcodes can be checked one by one
_PyUnpickler: Any = pickle._Unpickler


class SnapshotUnpickler(_PyUnpickler):
    """Unpickles a snapshot into `rack` and nothing else (module docstring): the Python
    unpickler, whose opcodes that call something are checked here."""

    dispatch: dict[int, Callable[..., None]] = dict(_PyUnpickler.dispatch)

    def __init__(self, file: io.BytesIO, rack: Rack, nvram: NvramStore | None,
                 memory: Segment | None) -> None:
        super().__init__(file)
        self.rack, self.nvram, self.memory = rack, nvram, memory
        self._shared: dict[int, Any] = {}
        #: id of a shared region's new memory -> its offset in the new segment
        self.shared_offsets: dict[int, int] = {}
        self._callable: set[int] = set()  # ids of what find_class gave that may be called
        self._found: set[int] = set()  # ids of the classes find_class gave
        self._codes: dict[str, CodeIndex] = {}

    def find_class(self, module: str, name: str) -> Any:
        obj = _lookup(module, name)
        if obj is None:
            raise bad(f"corrupt: it names {module}.{name}, which a snapshot never holds")
        if (module, name) in _CALLABLE or obj in _OWN_CALLABLES or (
                isinstance(obj, type) and issubclass(obj, enum.Enum | tuple)
                and module.partition(".")[0] in _PACKAGES):
            self._callable.add(id(obj))
        if isinstance(obj, type):
            self._found.add(id(obj))
        return obj

    def persistent_load(self, pid: Any) -> Any:  # noqa: C901 - one case per persistent id
        if not isinstance(pid, tuple) or not pid or not isinstance(pid[0], str):
            raise bad("corrupt: a persistent id that is not one")
        kind, args = pid[0], pid[1:]
        if kind == "rack":
            return self.rack
        if kind == "sink":
            return self.rack.sink
        if kind == "nvram":
            return self.nvram
        if kind == "memory":
            return self.memory
        if kind == "writer":
            return NvramWriter(self.nvram, str(args[0])) if self.nvram is not None else None
        if kind == "logger":
            name = str(args[0])
            if not name.startswith("vdevd"):
                raise bad(f"corrupt: logger {name!r}")
            return logging.getLogger(name)
        if kind == "lock":
            return threading.RLock() if args[0] else threading.Lock()
        if kind == "dropped":
            return None
        if kind == "proxy" and isinstance(args[0], dict):
            return types.MappingProxyType(args[0])
        if kind == "method":
            return _method(*args)
        if kind == "compiled":
            return _compiled(*args)
        if kind == "shm":
            return self._shm(*args)
        if kind == "memview":
            base, offset, size, readonly = args
            view = memoryview(base)[offset:offset + size]
            if len(view) != size:
                raise bad("corrupt: a view beyond its buffer")
            return view.toreadonly() if readonly else view
        if kind == "view":
            root, offset, shape, strides, dtype = args
            if not isinstance(dtype, np.dtype):
                raise bad("corrupt: a view of no dtype")
            return np.ndarray(shape, dtype, buffer=root, offset=offset, strides=strides)
        raise bad(f"corrupt: an unknown persistent id {kind!r}")

    def _shm(self, index: int, data: bytes | None) -> Any:
        """A shared region's memory: a part of the new segment (private memory without one)
        holding the saved bytes; its offset in the segment is kept (`shared_offsets`)."""
        if data is None:
            return self._shared[index]
        shared = self.memory.allocate(len(data)) if self.memory is not None else None
        buf: Any = shared[0] if shared is not None else bytearray(len(data))
        buf[:] = data
        self._shared[index] = buf
        if shared is not None:
            self.shared_offsets[id(buf)] = shared[1]
        return buf

    # the opcodes that call or set something: only what find_class allowed
    def load_reduce(self) -> None:
        func = self.stack[-2]
        if id(func) not in self._callable:
            raise bad(f"corrupt: it calls {func!r}")
        if func is _make_function:  # with the code indexes of this load
            args = self.stack.pop()
            self.stack[-1] = self._function(*args)
            return
        super().load_reduce()

    def _function(self, module: str, qualname: str, line: int, n: int, defaults: Any,
                  kwdefaults: Any, cells: tuple[Any, ...]) -> types.FunctionType:
        index = self._codes.get(module)
        if index is None:
            index = self._codes[module] = CodeIndex(module)
        return _make_function(module, qualname, line, n, defaults, kwdefaults, cells, index)

    dispatch[pickle.REDUCE[0]] = load_reduce

    def load_newobj(self) -> None:
        if id(self.stack[-2]) not in self._found:
            raise bad(f"corrupt: it builds a {self.stack[-2]!r}")
        super().load_newobj()

    dispatch[pickle.NEWOBJ[0]] = load_newobj

    def load_newobj_ex(self) -> None:
        if id(self.stack[-3]) not in self._found:
            raise bad(f"corrupt: it builds a {self.stack[-3]!r}")
        super().load_newobj_ex()

    dispatch[pickle.NEWOBJ_EX[0]] = load_newobj_ex

    def load_build(self) -> None:
        inst = self.stack[-2]
        if isinstance(inst, type | types.FunctionType | types.BuiltinFunctionType
                      | types.MethodType | types.ModuleType):
            raise bad(f"corrupt: it sets the state of {inst!r}")
        super().load_build()

    dispatch[pickle.BUILD[0]] = load_build

    def _refused(self) -> None:
        raise bad("corrupt: an opcode a snapshot never holds")

    for _op in (pickle.INST, pickle.OBJ, pickle.EXT1, pickle.EXT2, pickle.EXT4):
        dispatch[_op[0]] = _refused
    del _op


def _lookup(module: str, name: str) -> Any:
    """A class or function of vdevd (a module already imported), or one of _ALLOWED_GLOBALS;
    None for anything else."""
    if (module, name) in _ALLOWED_GLOBALS:
        mod = sys.modules.get(module)
        return getattr(mod, name, None) if mod is not None else None
    if module.partition(".")[0] not in _PACKAGES or name.startswith("__") \
            or module in _NEVER_NAMED:
        return None
    obj: Any = sys.modules.get(module)
    for part in name.split("."):
        if obj is None or part.startswith("__"):
            return None
        obj = vars(obj).get(part) if isinstance(obj, type | types.ModuleType) else None
        if isinstance(obj, staticmethod):
            obj = obj.__func__
    if isinstance(obj, type | types.FunctionType) and str(obj.__module__).partition(".")[0] in \
            _PACKAGES:
        return obj
    return None


def _method(obj: Any, name: Any) -> Any:
    """`obj.name`, a method defined by its class (a bound method the graph held)."""
    if not isinstance(name, str) or name.startswith("__") and name != "__call__":
        raise bad(f"corrupt: method {name!r}")
    for klass in type(obj).__mro__:
        attr = vars(klass).get(name)
        if attr is not None:
            if isinstance(attr, types.FunctionType | types.MethodDescriptorType
                          | types.WrapperDescriptorType | classmethod | staticmethod):
                return getattr(obj, name)
            break
    raise bad(f"corrupt: {type(obj).__name__} has no method {name!r}")

