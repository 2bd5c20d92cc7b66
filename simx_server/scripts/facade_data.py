"""CoppeliaSim 4.x's data calls (mixin of :class:`simx_server.scripts.facade.ScriptSim`): table
packing, buffer signals, custom data on objects and the scene, the 4.8+ properties API over
them, and rotation arithmetic.

* ``packTable`` / ``unpackTable`` use CBOR (RFC 8949, the ``cbor2`` library): CoppeliaSim 4.x's
  ``packTable(t, 1)`` format, which its ``unpackTable`` reads back; a buffer packed by simx is
  unpacked by simx and by CoppeliaSim (its own older scheme-0 buffers are not read: an error
  says so).
* Custom data (``writeCustomDataBlockEx`` and the typed ``writeCustom*Data``) is kept per object
  (``sim.handle_scene`` for the scene) for the server's lifetime, bounded like signals.
* Properties: ``customData.NAME`` and ``signal.NAME`` on any handle map onto the two stores,
  plus read-only object properties (``alias``, ``objectType``, ``parentHandle``, ``mass`` of a
  shape...); typed getters/setters check the value's type.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import cbor2
import numpy as np

from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base.arguments import quote
from simx_server.scripts.signals import Signals
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector
from simx_server.sim.objects import SHAPE
from simx_server.sim.rotations import matrix_from_euler

HANDLE_SCENE, HANDLE_APP = -12, -13
_MAX_CUSTOM_BYTES = 16 << 20  # all custom data of a server
_CBOR_FIRST = set(range(0x80, 0xC0)) | {0xF6}  # CBOR arrays, maps, null


def _plain(value: Any, depth: int = 0) -> Any:
    """A value CBOR can carry (lists for tuples and numpy arrays); bounded nesting."""
    if depth > 64:
        raise ArgumentError("packTable: table nested more than 64 levels")
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v, depth + 1) for v in value]
    if isinstance(value, dict):
        return {_plain(k, depth + 1): _plain(v, depth + 1) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value


class DataCalls:
    """Packing, buffer signals, custom data, properties, rotation arithmetic (facade mixin)."""

    _signals: Signals

    # ------------------------------------------------------------------ packing
    def packTable(self, aTable: Any, scheme: Any = 0) -> bytes:  # noqa: N802, N803
        """A table (list or dict, nested) as a CBOR buffer (``scheme`` 0 or 1: simx writes CBOR
        for both; CoppeliaSim reads it with ``unpackTable``)."""
        if not isinstance(aTable, (list, tuple, dict, np.ndarray)):
            raise ArgumentError(f"packTable needs a table, got {type(aTable).__name__}")
        _int(scheme, "scheme")
        try:
            return cbor2.dumps(_plain(aTable))
        except (TypeError, ValueError, cbor2.CBOREncodeError) as exc:
            raise ArgumentError(f"packTable: {exc}") from None

    def unpackTable(self, buffer: Any) -> Any:  # noqa: N802
        """The table of a buffer :meth:`packTable` wrote (CBOR)."""
        raw = _bytes(buffer, "buffer")
        if not raw or raw[0] not in _CBOR_FIRST:
            raise ArgumentError("unpackTable reads CBOR buffers (packTable's); CoppeliaSim's scheme-0 "
                                "binary format is not supported")
        try:
            return cbor2.loads(raw, max_depth=65, allow_indefinite=False)
        except (cbor2.CBORDecodeError, ValueError, RecursionError) as exc:
            raise ArgumentError(f"unpackTable: not a CBOR table ({exc})") from None

    def copyTable(self, original: Any) -> Any:  # noqa: N802
        """A deep copy of a table."""
        return _plain(original)

    # ----------------------------------------------------------- buffer signals
    def setBufferSignal(self, signalName: Any, signalValue: Any) -> None:  # noqa: N802, N803
        """A buffer signal (CoppeliaSim 4: the string signals of V-REP, one store)."""
        self._signals.set(Signals.STRING, _text(signalName, "signalName"), _bytes(signalValue, "signalValue"),
                          by_script=True)

    def getBufferSignal(self, signalName: Any) -> bytes | None:  # noqa: N802, N803
        return self._signals.get(Signals.STRING, _text(signalName, "signalName"))

    def clearBufferSignal(self, signalName: Any = None) -> None:  # noqa: N802, N803
        self._signals.clear(Signals.STRING, None if signalName is None else _text(signalName, "signalName"))

    def getSignalName(self, signalIndex: Any, signalType: Any) -> str | None:  # noqa: N802, N803
        """Name of the ``signalIndex``-th signal of ``signalType`` (0 int, 1 float, 2 string /
        buffer), in name order; nil past the last."""
        kind = {0: Signals.INT, 1: Signals.FLOAT, 2: Signals.STRING}.get(_int(signalType, "signalType"))
        if kind is None:
            raise ArgumentError("signalType: 0 (integer), 1 (float) or 2 (string/buffer)")
        names = self._signals.names(kind)
        i = _int(signalIndex, "signalIndex")
        return names[i] if 0 <= i < len(names) else None

    # -------------------------------------------------------------- custom data
    def _custom(self, handle: Any) -> dict[str, bytes]:
        h = _int(handle, "objectHandle")
        if h not in (HANDLE_SCENE, HANDLE_APP):
            h = self._world.get(self._h(h)).handle
        sim = getattr(self, "_sim", None)
        holder = sim if sim is not None else self
        store = getattr(holder, "custom_data", None)
        if store is None:
            store = holder.custom_data = {}
        if h in store and h >= 0 and h not in self._world.objects:
            del store[h]
        return store.setdefault(h, {})

    def writeCustomDataBlockEx(self, objectHandle: Any, tagName: Any, data: Any, options: Any = None) -> None:  # noqa: N802, N803
        """Store ``data`` (bytes) under ``tagName`` on an object (``sim.handle_scene``: the
        scene); empty data removes the tag. At most 16 MiB of custom data in all."""
        block, tag = self._custom(objectHandle), _text(tagName, "tagName")
        raw = b"" if data is None else _bytes(data, "data")
        total = sum(len(v) for store in getattr(getattr(self, "_sim", None) or self, "custom_data", {}).values()
                    for v in store.values())
        if total - len(block.get(tag, b"")) + len(raw) > _MAX_CUSTOM_BYTES:
            raise ArgumentError(f"custom data would exceed {_MAX_CUSTOM_BYTES} bytes in all")
        if raw:
            block[tag] = raw
        else:
            block.pop(tag, None)

    def readCustomDataBlockEx(self, objectHandle: Any, tagName: Any, options: Any = None) -> bytes | None:  # noqa: N802, N803
        """The data stored under ``tagName``; nil when none."""
        return self._custom(objectHandle).get(_text(tagName, "tagName"))

    def readCustomDataTags(self, objectHandle: Any) -> list[str]:  # noqa: N802, N803
        """The tags with data on an object, sorted."""
        return sorted(self._custom(objectHandle))

    writeCustomBufferData = writeCustomDataBlockEx  # noqa: N815
    readCustomBufferData = readCustomDataBlockEx  # noqa: N815

    def writeCustomStringData(self, objectHandle: Any, tagName: Any, data: Any) -> None:  # noqa: N802, N803
        self.writeCustomDataBlockEx(objectHandle, tagName, _text(data, "data").encode("utf-8"))

    def readCustomStringData(self, objectHandle: Any, tagName: Any) -> str | None:  # noqa: N802, N803
        raw = self.readCustomDataBlockEx(objectHandle, tagName)
        return None if raw is None else raw.decode("utf-8", "replace")

    def writeCustomTableData(self, objectHandle: Any, tagName: Any, data: Any, options: Any = None) -> None:  # noqa: N802, N803
        """Store a table (packed as :meth:`packTable`)."""
        self.writeCustomDataBlockEx(objectHandle, tagName, self.packTable(data) if data else b"")

    def readCustomTableData(self, objectHandle: Any, tagName: Any, options: Any = None) -> Any:  # noqa: N802, N803
        """The stored table; an empty table when none."""
        raw = self.readCustomDataBlockEx(objectHandle, tagName)
        return {} if raw is None else self.unpackTable(raw)

    # --------------------------------------------------------------- properties
    def _object_property(self, handle: int, name: str) -> Any:
        obj = self._world.get(handle)
        values = {"alias": lambda: obj.name.split("#")[0], "objectType": lambda: obj.type,
                  "parentHandle": lambda: obj.parent, "handle": lambda: obj.handle, "objectUid": lambda: obj.handle,
                  "pose": lambda: self._world.position(handle, -1) + self._world.quaternion(handle, -1)}
        if obj.type == SHAPE:
            values["mass"] = lambda: float(self._world.model.body_mass[obj.mj_id])
        if name not in values:
            raise UnknownObjectError(f"object {obj.name!r} has no property {quote(name)} in simx "
                                     f"(it has customData.*, signal.* on the scene, {', '.join(sorted(values))})")
        return values[name]()

    def getProperty(self, target: Any, pName: Any, options: Any = None) -> Any:  # noqa: N802, N803
        """A property of an object or of the scene (``sim.handle_scene``): ``customData.TAG``
        (the custom data block, unpacked when it is a packed table), ``signal.NAME`` (a signal of
        any kind), ``alias``, ``objectType``, ``parentHandle``, ``pose``, ``mass`` (shapes).
        Errors: no such property (``{noError = true}``: nil)."""
        name, h = _text(pName, "pName"), _int(target, "target")
        try:
            if name.startswith("customData."):
                raw = self.readCustomDataBlockEx(h, name[11:])
                if raw is None:
                    raise UnknownObjectError(f"no property {quote(name)}")
                if (h, name) in getattr(getattr(self, "_sim", None) or self, "custom_types", {}):
                    return cbor2.loads(raw)  # written by a typed setter (facade_props)
                return self.unpackTable(raw) if raw[:1] and raw[0] in _CBOR_FIRST else raw
            if name.startswith("signal.") and h == HANDLE_SCENE:
                for kind in Signals.KINDS:
                    v = self._signals.get(kind, name[7:])
                    if v is not None:
                        return v
                raise UnknownObjectError(f"no property {quote(name)}")
            if h in (HANDLE_SCENE, HANDLE_APP):
                raise UnknownObjectError(f"the scene has no property {quote(name)} in simx")
            return self._object_property(self._h(h), name)
        except UnknownObjectError:
            if isinstance(options, dict) and options.get("noError"):
                return None
            raise

    def setProperty(self, target: Any, pName: Any, pValue: Any, pType: Any = None) -> None:  # noqa: N802, N803
        """Set ``customData.TAG`` (tables packed, bytes and text as they are) or, on the scene,
        ``signal.NAME`` (an integer, float or buffer signal by the value's type)."""
        name, h = _text(pName, "pName"), _int(target, "target")
        if name.startswith("customData."):
            value = pValue if isinstance(pValue, (bytes, bytearray)) else (
                pValue.encode() if isinstance(pValue, str) else cbor2.dumps(_plain(pValue)))
            self.writeCustomDataBlockEx(h, name[11:], value)
        elif name.startswith("signal.") and h == HANDLE_SCENE:
            kind = Signals.INT if isinstance(pValue, int) and not isinstance(pValue, bool) else (
                Signals.FLOAT if isinstance(pValue, float) else Signals.STRING)
            self._signals.set(kind, name[7:], pValue, by_script=True)
        else:
            raise ArgumentError(f"property {quote(name)} cannot be set in simx (customData.* and the scene's "
                                "signal.* can)")

    def removeProperty(self, target: Any, pName: Any, options: Any = None) -> None:  # noqa: N802, N803
        name, h = _text(pName, "pName"), _int(target, "target")
        if name.startswith("customData."):
            self.writeCustomDataBlockEx(h, name[11:], b"")
        elif name.startswith("signal.") and h == HANDLE_SCENE:
            for kind in Signals.KINDS:
                self._signals.clear(kind, name[7:])
        else:
            raise ArgumentError(f"property {quote(name)} cannot be removed")

    # ------------------------------------------------------------- rotations
    def getRotationAxis(self, matrixStart: Any, matrixGoal: Any) -> tuple[list[float], float]:  # noqa: N802, N803
        """``axis, angle``: the rotation (world axis, rad in [0, pi]) from one 12-number matrix
        (or 7-number pose) to another."""
        ra, rb = (self._rotation(v, n) for v, n in ((matrixStart, "matrixStart"), (matrixGoal, "matrixGoal")))
        r = rb @ ra.T
        angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1) / 2)))
        axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
        n = np.linalg.norm(axis)
        if n < 1e-9:  # 0 or pi: the axis from the symmetric part
            if angle < 1e-9:
                return [0.0, 0.0, 1.0], 0.0
            w, v = np.linalg.eigh((r + np.eye(3)) / 2)
            axis, n = v[:, int(np.argmax(w))], 1.0
        return (axis / n).tolist(), angle

    @staticmethod
    def _rotation(value: Any, what: str) -> np.ndarray:
        if isinstance(value, (list, tuple)) and len(value) == 7:
            x, y, z, w = _vector(value, 7, what)[3:]
            from simx_server.sim.rotations import matrix_from_quaternion
            return np.asarray(matrix_from_quaternion(x, y, z, w))
        return np.array(_vector(value, 12, what)).reshape(3, 4)[:, :3]

    def interpolateMatrices(self, matrixIn1: Any, matrixIn2: Any, interpolFactor: Any) -> list[float]:  # noqa: N802, N803
        """The matrix ``interpolFactor`` (0..1) of the way: positions linear, rotation along the
        shortest arc (12 numbers)."""
        a = np.array(_vector(matrixIn1, 12, "matrixIn1")).reshape(3, 4)
        b = np.array(_vector(matrixIn2, 12, "matrixIn2")).reshape(3, 4)
        t = _num(interpolFactor, "interpolFactor")
        axis, angle = self.getRotationAxis(matrixIn1, matrixIn2)
        k = np.array(axis)
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        th = t * angle
        rot = np.eye(3) + math.sin(th) * kx + (1 - math.cos(th)) * kx @ kx
        out = np.hstack([rot @ a[:, :3], (a[:, 3] + t * (b[:, 3] - a[:, 3])).reshape(3, 1)])
        return out.reshape(12).tolist()

    def yawPitchRollToAlphaBetaGamma(self, yawAngle: Any, pitchAngle: Any, rollAngle: Any) -> tuple[float, float, float]:  # noqa: N802, N803
        """CoppeliaSim's conversion: R = Rz(yaw) Ry(pitch) Rx(roll) as Euler angles alpha, beta,
        gamma (R = Rx(alpha) Ry(beta) Rz(gamma)), rad."""
        y, p, r = (_num(v, n) for v, n in ((yawAngle, "yawAngle"), (pitchAngle, "pitchAngle"), (rollAngle, "rollAngle")))
        rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
        ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
        rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
        return _euler_xyz(rz @ ry @ rx)

    def alphaBetaGammaToYawPitchRoll(self, alphaAngle: Any, betaAngle: Any, gammaAngle: Any) -> tuple[float, float, float]:  # noqa: N802, N803
        """The inverse of :meth:`yawPitchRollToAlphaBetaGamma` (rad)."""
        r = np.asarray(matrix_from_euler(*(_num(v, n) for v, n in ((alphaAngle, "alphaAngle"), (betaAngle, "betaAngle"),
                                                                     (gammaAngle, "gammaAngle")))))
        pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
        if abs(r[2, 0]) < 1 - 1e-12:
            return math.atan2(r[1, 0], r[0, 0]), pitch, math.atan2(r[2, 1], r[2, 2])
        return math.atan2(-r[0, 1], r[1, 1]), pitch, 0.0

    def getQuaternionInverse(self, quat: Any) -> list[float]:  # noqa: N802
        """The inverse of a unit quaternion ``[x, y, z, w]``."""
        x, y, z, w = _vector(quat, 4, "quat")
        return [-x, -y, -z, w]

    def getConfigDistance(self, configA: Any, configB: Any, metric: Any = None, types: Any = None) -> float:  # noqa: N802, N803
        """Weighted Euclidean distance between two configurations (``metric``: weights, default
        1s); ``types`` 1 revolute (angles wrap: the shorter way round), 0 others."""
        a, b = (np.array(_vector(v, len(v) if isinstance(v, (list, tuple)) else -1, n))
                for v, n in ((configA, "configA"), (configB, "configB")))
        if a.shape != b.shape:
            raise ArgumentError("configA and configB differ in length")
        d = b - a
        if types is not None:
            t = np.array(_vector(types, len(a), "types"))
            d = np.where(t == 1, (d + np.pi) % (2 * np.pi) - np.pi, d)
        w = np.ones(len(a)) if metric is None else np.array(_vector(metric, len(a), "metric"))
        return float(np.sqrt(np.sum((w * d) ** 2)))

    if TYPE_CHECKING:  # provided by the facade
        _world: Any

        def _h(self, handle: Any, what: str = "object handle") -> int: ...


def _euler_xyz(r: np.ndarray) -> tuple[float, float, float]:
    """alpha, beta, gamma of R = Rx(alpha) Ry(beta) Rz(gamma) (V-REP's Euler angles)."""
    beta = math.asin(max(-1.0, min(1.0, r[0, 2])))
    if abs(r[0, 2]) < 1 - 1e-12:
        return math.atan2(-r[1, 2], r[2, 2]), beta, math.atan2(-r[0, 1], r[0, 0])
    return math.atan2(r[2, 1], r[1, 1]), beta, 0.0
