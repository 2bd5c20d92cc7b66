"""The server's signal store: V-REP's integer, float and string signals, named values shared by
child scripts and clients (``simxSetIntegerSignal``, ``sim.setInt32Signal`` ...).
"""

from __future__ import annotations

from typing import Any

from simx_wire.protocol import ArgumentError
from simx_server.base import limits as L
from simx_server.base.arguments import quote


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
        beyond the store's bounds (then nothing changes).

        Args:
            kind: INT, FLOAT or STRING.
            name: the signal's name.
            value: an integer, a number, or bytes/text.
            by_script: set by a child script: cleared when the simulation stops.
        """
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
        """Value of signal ``name`` of ``kind``, ``default`` when it is not set.

        Args:
            kind: INT, FLOAT or STRING.
            name: the signal's name.
            default: what an unset signal gives.

        Returns:
            int, float or bytes, or ``default``.

        Raises:
            ArgumentError: an unknown kind or a bad name.
        """
        self._check(kind, name)
        return self._values[kind].get(name, default)

    def _pop(self, kind: str, name: str) -> None:
        old = self._values[kind].pop(name, None)
        if old is not None:
            self.size -= self._size(name, old)
            self.count -= 1

    def clear(self, kind: str | None = None, name: str | None = None) -> None:
        """Clear one signal, every signal of ``kind`` (``name`` None) or everything (both None).

        Args:
            kind: INT, FLOAT, STRING or None.
            name: the signal's name, or None.

        Raises:
            ArgumentError: an unknown kind or a bad name.
        """
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
        """Names of the signals of ``kind`` that are set.

        Args:
            kind: INT, FLOAT or STRING.

        Returns:
            The names, sorted.
        """
        self._check(kind, "")
        return sorted(self._values[kind])

    # typed accessors
    def set_int(self, name: str, value: int, *, by_script: bool = False) -> None:
        """Set integer signal ``name`` (:meth:`set`)."""
        self.set(self.INT, name, value, by_script=by_script)

    def get_int(self, name: str, default: int | None = None) -> int | None:
        """Integer signal ``name``, ``default`` when not set (:meth:`get`)."""
        return self.get(self.INT, name, default)

    def set_float(self, name: str, value: float, *, by_script: bool = False) -> None:
        """Set float signal ``name`` (:meth:`set`)."""
        self.set(self.FLOAT, name, value, by_script=by_script)

    def get_float(self, name: str, default: float | None = None) -> float | None:
        """Float signal ``name``, ``default`` when not set (:meth:`get`)."""
        return self.get(self.FLOAT, name, default)

    def set_string(self, name: str, value: bytes | str, *, by_script: bool = False) -> None:
        """Set string signal ``name`` (:meth:`set`)."""
        self.set(self.STRING, name, value, by_script=by_script)

    def get_string(self, name: str, default: bytes | None = None) -> bytes | None:
        """String signal ``name`` as bytes, ``default`` when not set (:meth:`get`)."""
        return self.get(self.STRING, name, default)
