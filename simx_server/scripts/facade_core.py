"""The ``sim`` facade of child scripts and the signal store, on top of the world.

One :class:`SimFacade` per script serves Python scripts directly and Lua scripts through
:mod:`simx_server.scripts.lua`; V-REP's names and units. :class:`Signals` is the server's
store of integer, float and string signals.
"""

from __future__ import annotations

import logging
import struct
from typing import Any

import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base import limits as L
from simx_server.base.arguments import quote
from simx_server.scripts import shapes
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num  # noqa: F401
from simx_server.base.arguments import as_text as _text, as_vector as _vector  # noqa: F401 (the facade modules use them)
from simx_server.sim import ik
from simx_server.sim.world import World, matrix_from_euler, matrix_from_quaternion

log = logging.getLogger("simx.scripts")


def script_constants() -> dict[str, int]:
    """The ``sim.*`` constants of child scripts: every ``sim_X`` constant of vrepConst.py,
    simConst.py and the Lua API's extras (:data:`simx_wire.constants.SCRIPT_ONLY`) as
    ``sim.X`` (Lua also reads it as ``sim_X``), plus ``handle_world`` (-1)."""
    table = {**C.SIM_CONSTANTS, **C.VREP_CONSTANTS, **C.SCRIPT_ONLY}
    out = {name[4:]: value for name, value in table.items() if name.startswith("sim_")}
    out["handle_world"] = -1
    return out


SCRIPT_CONSTANTS: dict[str, int] = script_constants()


# --------------------------------------------------------------------------- signals
class Signals:
    """Integer, float and string signals: V-REP's named values shared by scripts and clients.

    One store per server: scripts use it through ``sim.setIntegerSignal`` & co., the remote
    ``simxSetIntegerSignal`` & co. can share the same instance. Kinds are ``"int"``, ``"float"``
    and ``"string"`` (string signals hold bytes, as V-REP's did). Signals set by scripts are
    cleared when the simulation stops (:meth:`clear_script_signals`), as in V-REP.

    The store is bounded (clients are untrusted): at most ``max_signals`` signals, names of at
    most ``max_name`` characters, string signals of at most ``max_bytes`` bytes and
    ``max_store_bytes`` in all (names and values; a number counts 8 bytes). Defaults: the
    ``*SIGNAL*`` bounds of :mod:`simx_server.base.limits`. A set beyond them raises ArgumentError
    naming the bound and changes nothing.
    """

    INT, FLOAT, STRING = "int", "float", "string"
    KINDS = (INT, FLOAT, STRING)

    def __init__(self, max_signals: int = L.MAX_SIGNALS, max_bytes: int = L.MAX_SIGNAL_BYTES,
                 max_store_bytes: int = L.MAX_SIGNAL_STORE_BYTES, max_name: int = L.MAX_SIGNAL_NAME) -> None:
        self._values: dict[str, dict[str, Any]] = {k: {} for k in self.KINDS}
        self._by_script: set[tuple[str, str]] = set()
        self.max_signals, self.max_bytes = max_signals, max_bytes
        self.max_store_bytes, self.max_name = max_store_bytes, max_name
        self.count = 0  # signals held
        self.size = 0  # bytes held: names and values

    def _check(self, kind: str, name: str) -> None:
        if kind not in self.KINDS:
            raise ArgumentError(f"signal kind must be one of {self.KINDS}, got {quote(kind)}")
        if not isinstance(name, str):
            raise ArgumentError(f"signal name must be a string, got {type(name).__name__}")
        if len(name) > self.max_name:
            raise ArgumentError(f"signal name {quote(name)} is longer than {self.max_name} characters "
                                "(simx_server.base.limits.MAX_SIGNAL_NAME)")

    @classmethod
    def _coerce(cls, kind: str, value: Any) -> Any:
        try:
            if kind == cls.INT:
                if isinstance(value, float) and not value.is_integer():
                    raise ValueError(f"{value!r} is not an integer")
                value = int(value)
                if not -1 << 63 <= value < 1 << 63:  # what msgpack (and a reply) can carry
                    raise ValueError("it does not fit in 64 bits")
                return value
            if kind == cls.FLOAT:
                return float(value)
        except (TypeError, ValueError, OverflowError) as exc:
            raise ArgumentError(f"bad {kind} signal value: {quote(str(exc))}") from None
        if isinstance(value, str):
            return value.encode("utf-8")
        if isinstance(value, (bytes, bytearray, memoryview)):
            return bytes(value)
        raise ArgumentError(f"a string signal holds bytes or str, got {type(value).__name__}")

    @staticmethod
    def _size(name: str, value: Any) -> int:
        return len(name) + (len(value) if type(value) is bytes else 8)

    def set(self, kind: str, name: str, value: Any, *, by_script: bool = False) -> None:
        """Set signal ``name`` of ``kind``; raises ArgumentError for a value of the wrong type or
        beyond the store's bounds (then nothing changes)."""
        self._check(kind, name)
        value = self._coerce(kind, value)
        values = self._values[kind]
        old = values.get(name)
        if type(value) is bytes and len(value) > self.max_bytes:
            raise ArgumentError(f"string signal {quote(name)} would hold {len(value)} bytes, more than "
                                f"{self.max_bytes} (simx_server.base.limits.MAX_SIGNAL_BYTES)")
        if old is None and self.count >= self.max_signals:
            raise ArgumentError(f"the signal store holds {self.count} signals, the most it takes "
                                f"(simx_server.base.limits.MAX_SIGNALS): clear some first")
        grow = self._size(name, value) - (0 if old is None else self._size(name, old))
        if self.size + grow > self.max_store_bytes:
            raise ArgumentError(f"signal {quote(name)} would bring the signal store to {self.size + grow} bytes, "
                                f"more than {self.max_store_bytes} (simx_server.base.limits.MAX_SIGNAL_STORE_BYTES): "
                                "clear some first")
        values[name] = value
        self.size += grow
        self.count += old is None
        if by_script:
            self._by_script.add((kind, name))
        else:
            self._by_script.discard((kind, name))

    def get(self, kind: str, name: str, default: Any = None) -> Any:
        """Value of signal ``name`` of ``kind``, ``default`` when it is not set."""
        self._check(kind, name)
        return self._values[kind].get(name, default)

    def _pop(self, kind: str, name: str) -> None:
        old = self._values[kind].pop(name, None)
        if old is not None:
            self.size -= self._size(name, old)
            self.count -= 1

    def clear(self, kind: str | None = None, name: str | None = None) -> None:
        """Clear one signal, every signal of ``kind`` (``name`` None) or everything (both None)."""
        for k in self.KINDS if kind is None else (kind,):
            self._check(k, "" if name is None else name)
            if name is None:
                for n in list(self._values[k]):
                    self._pop(k, n)
                self._by_script = {s for s in self._by_script if s[0] != k}
            else:
                self._pop(k, name)
                self._by_script.discard((k, name))

    def clear_script_signals(self) -> None:
        """Clear the signals last set by scripts (V-REP clears them at simulation end)."""
        for kind, name in self._by_script:
            self._pop(kind, name)
        self._by_script.clear()

    def names(self, kind: str) -> list[str]:
        """Names of the signals of ``kind`` that are set."""
        self._check(kind, "")
        return sorted(self._values[kind])

    # typed accessors
    def set_int(self, name: str, value: int, *, by_script: bool = False) -> None:
        self.set(self.INT, name, value, by_script=by_script)

    def get_int(self, name: str, default: int | None = None) -> int | None:
        return self.get(self.INT, name, default)

    def set_float(self, name: str, value: float, *, by_script: bool = False) -> None:
        self.set(self.FLOAT, name, value, by_script=by_script)

    def get_float(self, name: str, default: float | None = None) -> float | None:
        return self.get(self.FLOAT, name, default)

    def set_string(self, name: str, value: bytes | str, *, by_script: bool = False) -> None:
        self.set(self.STRING, name, value, by_script=by_script)

    def get_string(self, name: str, default: bytes | None = None) -> bytes | None:
        return self.get(self.STRING, name, default)


# ---------------------------------------------------------------------- the facade
#: pack/unpack formats: struct code and item size of each V-REP pack*Table function.
_PACK_FORMATS = {"Int32": "i", "UInt32": "I", "Float": "f", "Double": "d", "UInt8": "B", "UInt16": "H"}


class SimFacade:
    """V-REP's ``sim`` API for child scripts, on top of the world (V-REP's names and units).

    The same object serves Python scripts directly and Lua scripts through
    :mod:`simx_server.scripts.lua` (every public method becomes ``sim.NAME`` there, every
    constant of :func:`script_constants` ``sim.CONSTANT``). Vectors are lists (Lua tables),
    strings may be ``str`` or ``bytes``, buffers are ``bytes``. Errors raise the simx exceptions
    (UnknownObjectError, ObjectTypeError, ArgumentError); Lua sees them as Lua errors.

    Args:
        world: the scene.
        owner: handle of the object the script is attached to (``sim.handle_self``).
        signals: the signal store (one per server).
        label: how log lines name the script.
    """

    def __init__(self, world: World, owner: int, signals: Signals | None = None, label: str = ""):
        self._world = world
        self._owner = owner
        self._signals = signals if signals is not None else Signals()
        self._label = label or world.get(owner).name

    def __getattr__(self, name: str) -> Any:
        if name in SCRIPT_CONSTANTS:
            return SCRIPT_CONSTANTS[name]
        raise AttributeError(f"sim.{name} is not available in simx (docs/SCRIPTS.md lists what is)")

    # ----------------------------------------------------------------- helpers
    def _h(self, handle: Any, what: str = "object handle") -> int:
        h = _int(handle, what)
        return self._owner if h == C.sim_handle_self else h

    def _rel(self, relative_to: Any) -> int:
        rel = self._h(relative_to, "relativeToObjectHandle")
        if rel not in (-1, C.sim_handle_parent):
            self._world.get(rel)
        return rel

    # ----------------------------------------------------------------- objects
    def getObjectHandle(self, name: Any) -> int:  # noqa: N802 (V-REP's names)
        """Handle of the object called ``name`` (``sim.handle_self``: the script's object).

        Raises UnknownObjectError (a Lua error) for an unknown name, as V-REP did."""
        if not isinstance(name, (str, bytes, bytearray)):
            if _int(name, "object name") != C.sim_handle_self:
                raise ArgumentError(f"object name must be a string or sim.handle_self, got {name!r}")
            return self._owner
        return self._world.resolve(_text(name, "object name")).handle

    def getObject(self, path: Any, options: dict | None = None) -> int:  # noqa: N802
        """CoppeliaSim 4.3's lookup: a name or ``/path``; ``"."`` is the script's object.

        ``options = {noError = true}`` answers -1 instead of an error for an unknown object."""
        p = _text(path, "object path")
        if p == ".":
            return self._owner
        try:
            return self._world.resolve(p).handle
        except UnknownObjectError:
            if isinstance(options, dict) and options.get("noError"):
                return -1
            raise

    def getObjectName(self, handle: Any) -> str:  # noqa: N802
        """Name of the object ``handle``."""
        return self._world.get(self._h(handle)).name

    getObjectAlias = getObjectName  # noqa: N815 (CoppeliaSim 4.3 name)

    def getObjectType(self, handle: Any) -> int:  # noqa: N802
        """Type of the object (``sim.object_joint_type`` ...)."""
        return self._world.get(self._h(handle)).type

    def getObjectParent(self, handle: Any) -> int:  # noqa: N802
        """Handle of the object's parent, -1 for the world."""
        return self._world.get(self._h(handle)).parent

    def getObjectAssociatedWithScript(self, script: Any) -> int:  # noqa: N802
        """The script's object (only ``sim.handle_self`` is a script handle in simx)."""
        if _int(script, "script handle") != C.sim_handle_self:
            raise ArgumentError("simx knows only sim.handle_self as a script handle")
        return self._owner

    def getObjects(self, index: Any, object_type: Any) -> int:  # noqa: N802
        """The ``index``-th object (0-based) of ``object_type`` (``sim.handle_all``: any), or -1."""
        handles = self._world.objects_of_type(_int(object_type, "objectType"))
        i = _int(index, "index")
        return handles[i] if 0 <= i < len(handles) else -1

    # ------------------------------------------------------------------ joints
    def getJointPosition(self, handle: Any) -> float:  # noqa: N802
        """Joint position (rad or m)."""
        return self._world.joint_position(self._h(handle))

    def setJointPosition(self, handle: Any, position: Any) -> None:  # noqa: N802
        """Teleport a joint to ``position`` (rad or m)."""
        self._world.set_joint_position(self._h(handle), _num(position, "position"))

    def setJointTargetPosition(self, handle: Any, position: Any) -> None:  # noqa: N802
        """Target position of the joint's motor (rad or m), stored whatever the mode (2000/2001 decide)."""
        self._world.set_joint_target_position(self._h(handle), _num(position, "position"))

    def getJointTargetPosition(self, handle: Any) -> float:  # noqa: N802
        """Target position of a joint's motor (rad or m)."""
        return float(self._world.target_position[self._world.motor(self._h(handle))])

    def setJointTargetVelocity(self, handle: Any, velocity: Any) -> None:  # noqa: N802
        """Target velocity of the joint's motor (rad/s or m/s), stored whatever the mode (2000/2001 decide)."""
        self._world.set_joint_target_velocity(self._h(handle), _num(velocity, "velocity"))

    def getJointTargetVelocity(self, handle: Any) -> float:  # noqa: N802
        """Target velocity of a joint's motor (rad/s or m/s)."""
        return float(self._world.target_velocity[self._world.motor(self._h(handle))])

    def setJointForce(self, handle: Any, force: Any) -> None:  # noqa: N802
        """Maximum force/torque of the joint's motor (N or N·m)."""
        self._world.set_joint_force(self._h(handle), _num(force, "force"))

    setJointMaxForce = setJointForce  # noqa: N815 (CoppeliaSim 4 name)

    def getJointForce(self, handle: Any) -> float:  # noqa: N802
        """Force/torque the joint's motor applies (N or N·m)."""
        return self._world.joint_force(self._h(handle))

    def getJointMaxForce(self, handle: Any) -> float:  # noqa: N802
        """Maximum force/torque of the joint's motor (N or N·m)."""
        return self._world.joint_max_force(self._h(handle))

    # ------------------------------------------------------------------- poses
    def getObjectPosition(self, handle: Any, relative_to: Any) -> list[float]:  # noqa: N802
        """Position (m) relative to ``relative_to`` (-1 world, ``sim.handle_parent``)."""
        return self._world.position(self._h(handle), self._rel(relative_to))

    def getObjectOrientation(self, handle: Any, relative_to: Any) -> list[float]:  # noqa: N802
        """Euler angles alpha, beta, gamma (rad), R = Rx(alpha) Ry(beta) Rz(gamma)."""
        return self._world.orientation(self._h(handle), self._rel(relative_to))

    def getObjectQuaternion(self, handle: Any, relative_to: Any) -> list[float]:  # noqa: N802
        """Orientation as a quaternion (x, y, z, w)."""
        return self._world.quaternion(self._h(handle), self._rel(relative_to))

    def setObjectPosition(self, handle: Any, relative_to: Any, position: Any) -> None:  # noqa: N802
        """Move an object to ``position`` (m) in the frame of ``relative_to``."""
        self._set_pose(handle, relative_to, position=_vector(position, 3, "position"))

    def setObjectOrientation(self, handle: Any, relative_to: Any, euler: Any) -> None:  # noqa: N802
        """Turn an object to Euler angles (rad) in the frame of ``relative_to``."""
        self._set_pose(handle, relative_to, rotation=matrix_from_euler(*_vector(euler, 3, "eulerAngles")))

    def setObjectQuaternion(self, handle: Any, relative_to: Any, quaternion: Any) -> None:  # noqa: N802
        """Turn an object to quaternion (x, y, z, w) in the frame of ``relative_to``."""
        self._set_pose(handle, relative_to, rotation=matrix_from_quaternion(*_vector(quaternion, 4, "quaternion")))

    def _set_pose(self, handle: Any, relative_to: Any, position: list[float] | None = None,
                  rotation: np.ndarray | None = None) -> None:
        self._world.set_pose(self._h(handle), self._rel(relative_to), position=position, rotation=rotation)

    # -------------------------------------------------------------------- time
    def getSimulationTime(self) -> float:  # noqa: N802
        """Simulation time (s)."""
        return self._world.time

    def getSimulationTimeStep(self) -> float:  # noqa: N802
        """Simulation step dt (s)."""
        return self._world.dt

    # ----------------------------------------------------------------- signals
    def setIntegerSignal(self, name: Any, value: Any) -> None:  # noqa: N802
        """Set integer signal ``name``."""
        self._signals.set(Signals.INT, _text(name, "signal name"), value, by_script=True)

    def getIntegerSignal(self, name: Any) -> int | None:  # noqa: N802
        """Integer signal ``name``; None (Lua nil) when not set."""
        return self._signals.get(Signals.INT, _text(name, "signal name"))

    def clearIntegerSignal(self, name: Any = None) -> None:  # noqa: N802
        """Clear integer signal ``name`` (every integer signal when None)."""
        self._signals.clear(Signals.INT, None if name is None else _text(name, "signal name"))

    def setFloatSignal(self, name: Any, value: Any) -> None:  # noqa: N802
        """Set float signal ``name``."""
        self._signals.set(Signals.FLOAT, _text(name, "signal name"), _num(value, "value"), by_script=True)

    def getFloatSignal(self, name: Any) -> float | None:  # noqa: N802
        """Float signal ``name``; None (Lua nil) when not set."""
        return self._signals.get(Signals.FLOAT, _text(name, "signal name"))

    def clearFloatSignal(self, name: Any = None) -> None:  # noqa: N802
        """Clear float signal ``name`` (every float signal when None)."""
        self._signals.clear(Signals.FLOAT, None if name is None else _text(name, "signal name"))

    def setStringSignal(self, name: Any, value: Any) -> None:  # noqa: N802
        """Set string signal ``name`` (a byte string)."""
        self._signals.set(Signals.STRING, _text(name, "signal name"), _bytes(value, "value"), by_script=True)

    def getStringSignal(self, name: Any) -> bytes | None:  # noqa: N802
        """String signal ``name`` as bytes; None (Lua nil) when not set."""
        return self._signals.get(Signals.STRING, _text(name, "signal name"))

    def clearStringSignal(self, name: Any = None) -> None:  # noqa: N802
        """Clear string signal ``name`` (every string signal when None)."""
        self._signals.clear(Signals.STRING, None if name is None else _text(name, "signal name"))

    # ---------------------------------------------------------------- messages
    def addStatusbarMessage(self, message: Any) -> None:  # noqa: N802
        """Write ``message`` to the server log (there is no status bar)."""
        log.info("[%s] %s", self._label, _text(message, "message") if message is not None else "")

    # ----------------------------------------------------------------- packing
    def _pack(self, kind: str, values: Any, start: Any, count: Any) -> bytes:
        if isinstance(values, np.ndarray):
            values = values.tolist()
        if not isinstance(values, (list, tuple)):
            raise ArgumentError(f"pack{kind}Table needs a table of numbers, got {values!r}")
        s, n = _int(start, "startIndex"), _int(count, "count")
        if s < 0 or n < 0:
            raise ArgumentError("startIndex and count must not be negative")
        items = values[s:] if n == 0 else values[s:s + n]
        code = _PACK_FORMATS[kind]
        conv = (lambda v: _num(v, "value")) if code in "fd" else (lambda v: _int(v, "value"))
        try:
            return struct.pack(f"<{len(items)}{code}", *(conv(v) for v in items))
        except struct.error as exc:
            raise ArgumentError(f"pack{kind}Table: {exc}") from None

    def _unpack(self, kind: str, data: Any, start: Any, count: Any, offset: Any) -> list:
        raw = _bytes(data, "data")
        s, n, off = _int(start, "startIndex"), _int(count, "count"), _int(offset, "additionalByteOffset")
        if s < 0 or n < 0 or off < 0:
            raise ArgumentError("startIndex, count and additionalByteOffset must not be negative")
        code = _PACK_FORMATS[kind]
        size = struct.calcsize(code)
        raw = raw[off + s * size:]
        available = len(raw) // size
        n = available if n == 0 else min(n, available)
        return list(struct.unpack(f"<{n}{code}", raw[:n * size]))


def _table_functions(kind: str) -> tuple[Any, Any]:
    """``sim.pack<kind>Table`` and ``sim.unpack<kind>Table`` (little endian, V-REP's arguments)."""

    def pack(self: SimFacade, values: Any, startIndex: Any = 0, count: Any = 0) -> bytes:  # noqa: N803
        return self._pack(kind, values, startIndex, count)

    def unpack(self: SimFacade, data: Any, startIndex: Any = 0, count: Any = 0,  # noqa: N803
               additionalByteOffset: Any = 0) -> list:  # noqa: N803
        return self._unpack(kind, data, startIndex, count, additionalByteOffset)

    pack.__doc__ = f"Pack ``values[startIndex:][:count]`` (count 0: all) as little-endian {kind} items."
    unpack.__doc__ = (f"{kind} items of a little-endian buffer, from item ``startIndex`` "
                      f"(after ``additionalByteOffset`` bytes), ``count`` of them (0: all).")
    return pack, unpack


for _kind in _PACK_FORMATS:  # packInt32Table, unpackFloatTable, ... as V-REP names them
    _pack_fn, _unpack_fn = _table_functions(_kind)
    setattr(SimFacade, f"pack{_kind}Table", _pack_fn)
    setattr(SimFacade, f"unpack{_kind}Table", _unpack_fn)


# IK groups and imported shapes (their own modules; a name the facade defines itself wins).

for _name, _fn in {**ik.FACADE_FUNCTIONS, **shapes.FACADE_FUNCTIONS}.items():
    if not hasattr(SimFacade, _name):
        setattr(SimFacade, _name, _fn)

#: Names of the facade's functions (``sim.NAME`` in both languages).
FACADE_FUNCTIONS: tuple[str, ...] = tuple(sorted(
    n for n, v in vars(SimFacade).items() if not n.startswith("_") and callable(v)))
