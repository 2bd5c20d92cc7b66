"""V-REP 3.x script calls with no CoppeliaSim 4.x twin in the facade: script parameters, script
attributes and execution counts, custom data blocks, 16/32-bit boolean helpers, system time and
``simExtRemoteApiStart``.

:class:`LegacyCalls` is a mixin of :class:`simx_server.scripts.facade.ScriptSim`; the 3.x global
names reach these methods through :mod:`simx_server.scripts.legacy_names`. A script is named by
its object's handle in simx (``sim.getScriptHandle()`` is the script's object), so the script
handle arguments are object handles (``sim.handle_self``: this script).
"""

from __future__ import annotations

import logging
import time
from typing import Any

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError
from simx_server.scripts.facade_objects import HANDLE_SCENE
from simx_server.scripts.legacy_names import CONSTANTS as LEGACY_CONSTANTS
from simx_server.scripts.legacy_objects import LegacyObjectCalls
from simx_server.scripts.legacy_tubes import TubeCalls
from simx_server.scripts.legacy_wireless import WirelessCalls
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num, as_text as _text

log = logging.getLogger("simx.scripts")

#: Constants this module adds to ``sim.*`` (Lua: also ``sim_*``).
CONSTANTS: dict[str, int] = dict(LEGACY_CONSTANTS)

_ATTR = {name: LEGACY_CONSTANTS[name] for name in LEGACY_CONSTANTS if "attribute" in name}
_MAX_CUSTOM_DATA = 1 << 20  # bytes of one custom data block (limits of the scene's own store)


class RemoteApiPorts:
    """Ports scripts asked the legacy remote API to serve (``simExtRemoteApiStart(port)``).

    The script facade records requests (:meth:`request`); the transport takes them
    (:meth:`take`) on its own thread and says which ports it serves (:attr:`served`)."""

    def __init__(self) -> None:
        self.pending: list[int] = []
        self.served: set[int] = set()

    def request(self, port: int) -> None:
        if port not in self.served and port not in self.pending:
            self.pending.append(port)

    def take(self) -> list[int]:
        """The ports requested since the last call (in order), emptied."""
        out, self.pending = self.pending, []
        return out


class ThreadEnd(BaseException):
    """Raised inside a Python script's thread to end it (the simulation stopped, or it overran
    its time bound); not an ``Exception``, so ``except Exception`` does not swallow it."""


class PythonThread:
    """A Python script's ``sysCall_thread`` / ``sysCall_threadmain`` run as a coroutine: its own
    OS thread, but only ever running while the simulation thread waits for it (a hand-off in
    both directions), so the script sees the simulation as from the simulation thread.

    :meth:`resume` runs it until it yields (``sim.switchThread()``, ``sim.step()``,
    ``sim.wait``, ``sim.waitForSignal``) or ends, for at most ``timeout`` s: past that the thread
    is interrupted (an asynchronous :class:`ThreadEnd`, repeated every 50 ms until it lets go)
    and ended. :meth:`end` ends it at the simulation's stop.
    """

    def __init__(self, fn: Any, name: str):
        import threading

        self._go, self._back = threading.Semaphore(0), threading.Semaphore(0)
        self._ending = False
        self.alive = True
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(fn,), name=f"simx-script-thread {name}", daemon=True)
        self._thread.start()

    def _run(self, fn: Any) -> None:
        self._go.acquire()
        try:
            if not self._ending:
                fn()
        except ThreadEnd:
            pass
        except BaseException as exc:  # reported by resume() on the simulation thread
            self.error = exc
        finally:
            self.alive = False
            self._back.release()

    def in_thread(self) -> bool:
        import threading

        return threading.current_thread() is self._thread

    def switch(self) -> None:
        """In the thread: give the step back; returns when resumed (raises ThreadEnd at the end)."""
        self._back.release()
        self._go.acquire()
        if self._ending:
            raise ThreadEnd

    def resume(self, timeout: float) -> bool:
        """Run the thread until it yields or ends; True when it yielded in time, False when it
        overran ``timeout`` (it is then ended). Its error, if it raised one, is in :attr:`error`."""
        import ctypes

        if not self.alive:
            return True
        self._go.release()
        if self._back.acquire(timeout=timeout):
            return True
        self._ending = True
        ident = self._thread.ident
        for _ in range(40):  # interrupt it until it lets go (at most ~2 s)
            ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(ident), ctypes.py_object(ThreadEnd))
            if self._back.acquire(timeout=0.05):
                break
        self.alive = False
        return False

    def end(self) -> None:
        """End the thread (the simulation stops): it raises ThreadEnd where it waits."""
        if self.alive:
            self._ending = True
            self._go.release()
            self._back.acquire(timeout=1.0)
        self.alive = False


class PythonThreadCalls:
    """The thread functions of ``sim`` for Python scripts (a mixin of the facade; Lua scripts get
    their own from :data:`THREADS_LUA`)."""

    def _py_thread(self, what: str) -> PythonThread:
        script = getattr(self, "_script", None)
        thread = getattr(script, "py_thread", None)
        if thread is None or not thread.in_thread():
            raise ArgumentError(f"sim.{what} can only be called in a threaded script (sysCall_thread)")
        return thread

    def switchThread(self) -> int:  # noqa: N802
        """Give the rest of this step back; the thread resumes at the next step."""
        self._py_thread("switchThread").switch()
        return 1

    def step(self) -> None:
        """CoppeliaSim 4.6's name of :meth:`switchThread` in threads."""
        self._py_thread("step").switch()

    def wait(self, dt: Any, simulationTime: Any = True) -> float:  # noqa: N803
        """Yield until ``dt`` s of simulation time (``simulationTime`` false: wall time) passed."""
        thread = self._py_thread("wait")
        dt = _num(dt, "dt")
        if simulationTime is False:
            end = time.monotonic() + dt
            while time.monotonic() < end:
                thread.switch()
        else:
            end = self.getSimulationTime() + dt
            while self.getSimulationTime() < end - 1e-9:
                thread.switch()
        return 0.0

    def waitForSignal(self, name: Any) -> Any:  # noqa: N802
        """Yield until an integer, float or string signal ``name`` exists; returns its value."""
        thread = self._py_thread("waitForSignal")
        while True:
            for kind in ("int", "float", "string"):
                value = self._signals.get(kind, _text(name, "signal name"))
                if value is not None:
                    return value
            thread.switch()

    def setThreadAutomaticSwitch(self, allow: Any) -> int:  # noqa: N802
        """Python threads switch only where they call the functions above: accepted, returns 0."""
        return 0


def name_suffix(name: str) -> tuple[int, str]:
    """V-REP's name suffix: ``("robot#2")`` -> ``(2, "robot")``, ``("robot")`` -> ``(-1, "robot")``."""
    base, sep, tail = name.rpartition("#")
    return (int(tail), base) if sep and tail.isdigit() else (-1, name)


class LegacyCalls(TubeCalls, WirelessCalls, LegacyObjectCalls, PythonThreadCalls):
    """V-REP 3.x calls of child and customization scripts (a mixin of ScriptSim)."""

    # ---------------------------------------------------------------- names of copies
    def _suffix(self) -> int:
        if "_name_suffix" not in self.__dict__:  # a script's object; none for the world (ZMQ clients)
            self._name_suffix = name_suffix(self._world.get(self._owner).name)[0] if self._owner > 0 else -1
        return self._name_suffix

    def getObjectHandle(self, name: Any) -> int:  # noqa: N802
        """V-REP 3.x / CoppeliaSim 4.0-4.2's lookup with its automatic name suffix: in a script
        whose object is a copy (``robot#0``), ``getObjectHandle("motor")`` finds ``motor#0``, the
        motor of the same copy; ``"motor#"`` means the name without a suffix, and a name with a
        suffix or a path is taken as it is. ``sim.setNameSuffix(n)`` changes the suffix (-1:
        none). Raises UnknownObjectError for an unknown name, as V-REP did."""
        if isinstance(name, (str, bytes, bytearray)):
            text = _text(name, "object name")
            suffix = self._suffix()
            if text.endswith("#"):
                return self._world.resolve(text[:-1]).handle
            if suffix >= 0 and "#" not in text and not text.startswith(("/", ".", ":")):
                return self._world.resolve(f"{text}#{suffix}").handle
        return super().getObjectHandle(name)

    def getNameSuffix(self, name: Any = None) -> tuple[int, str]:  # noqa: N802
        """The suffix number of ``name`` (nil: the script's object) and the name without it."""
        text = self._world.get(self._owner).name if name is None else _text(name, "name")
        return name_suffix(text)

    def setNameSuffix(self, suffix: Any) -> int:  # noqa: N802
        """The suffix later ``getObjectHandle`` calls of this script append (-1: none)."""
        self._name_suffix = max(-1, _int(suffix, "nameSuffixNumber"))
        return 1

    # ---------------------------------------------------------------- the script itself
    def _own(self, script: Any, what: str) -> Any:
        h = _int(script, what)
        owner = self._owner if h == C.sim_handle_self else h
        me = getattr(self, "_script", None)
        if me is not None and owner == me.owner:
            return me
        manager = me.shared.get("manager") if me is not None else None
        other = manager.scripts.get(owner) if manager is not None else None
        if other is None:
            raise ArgumentError(f"{what}: object {owner} has no script")
        return other

    def getScriptSimulationParameter(self, scriptHandle: Any, parameterName: Any,  # noqa: N802, N803
                                     forceStringReturn: Any = False) -> Any:
        """3.x script simulation parameters (the scene's ``script_parameters=FILE.json``): the
        value of ``parameterName`` as a number when it reads as one (else a string; a string
        always with ``forceStringReturn``), nil when the script has no such parameter.
        ``sim.handle_all`` as the script: a table of the values of every script that has it."""
        name = _text(parameterName, "parameterName")
        h = _int(scriptHandle, "scriptHandle")
        if h == C.sim_handle_all:
            me = getattr(self, "_script", None)
            manager = me.shared.get("manager") if me is not None else None
            scripts = list(manager.scripts.values()) if manager is not None else [me]
            return [v for s in scripts if (v := _parameter(s, name, bool(forceStringReturn))) is not None]
        return _parameter(self._own(h, "scriptHandle"), name, bool(forceStringReturn))

    def setScriptSimulationParameter(self, scriptHandle: Any, parameterName: Any,  # noqa: N802, N803
                                     parameterValue: Any) -> int:  # noqa: N803
        """Set (or add) a script simulation parameter of the script; returns 1."""
        script = self._own(scriptHandle, "scriptHandle")
        name = _text(parameterName, "parameterName")
        value = parameterValue.decode("utf-8", "replace") if isinstance(parameterValue, bytes) else parameterValue
        for p in script.parameters:
            if p.get("name") == name:
                p["value"] = value
                return 1
        script.parameters.append({"name": name, "value": value, "unit": ""})
        return 1

    def getScriptExecutionCount(self) -> int:  # noqa: N802
        """How many times the script's life-cycle functions (or old-style passes) have run since
        the simulation started."""
        me = getattr(self, "_script", None)
        return me.executions if me is not None else 0

    def getScriptAssociatedWithObject(self, objectHandle: Any) -> int:  # noqa: N802, N803
        """The object's child script (its object's handle), -1 when it has none."""
        h = self._h(objectHandle)
        me = getattr(self, "_script", None)
        manager = me.shared.get("manager") if me is not None else None
        script = manager.scripts.get(h) if manager is not None else None
        return h if script is not None and script.kind == "child" else -1

    def getCustomizationScriptAssociatedWithObject(self, objectHandle: Any) -> int:  # noqa: N802, N803
        """The object's customization script (its object's handle), -1 when it has none."""
        h = self._h(objectHandle)
        me = getattr(self, "_script", None)
        manager = me.shared.get("manager") if me is not None else None
        script = manager.customization.get(h) if manager is not None else None
        return h if script is not None else -1

    def setScriptAttribute(self, scriptHandle: Any, attributeID: Any, value: Any) -> int:  # noqa: N802, N803
        """3.x script attributes: ``sim.scriptattribute_executioncount`` sets the script's
        execution count (V-REP 3.1.3's compatibility header of old scripts sets it to 0 at the
        first actuation pass, so that ``simGetScriptExecutionCount()==0`` marks it); the others
        are accepted and logged (simx runs every script every step, in object-tree order).
        Returns 1."""
        script = self._own(scriptHandle, "scriptHandle")
        if _int(attributeID, "attributeID") == _ATTR["scriptattribute_executioncount"]:
            script.executions = _int(value, "value")
            return 1
        log.debug("[%s] setScriptAttribute(%s, %r): no effect in simx", self._label, attributeID, value)
        return 1

    def getScriptAttribute(self, scriptHandle: Any, attributeID: Any) -> Any:  # noqa: N802, N803
        """``sim.scriptattribute_executioncount``, ``_scripttype``, ``_enabled`` (true),
        ``_executionorder`` (normal), ``_debuglevel`` (0)."""
        script = self._own(scriptHandle, "scriptHandle")
        a = _int(attributeID, "attributeID")
        if a == _ATTR["scriptattribute_executioncount"]:
            return script.executions
        if a == _ATTR["scriptattribute_scripttype"]:
            return C.sim_scripttype_childscript if script.kind == "child" else C.sim_scripttype_customizationscript
        if a == _ATTR["scriptattribute_enabled"]:
            return True
        if a == _ATTR["scriptattribute_executionorder"]:
            return LEGACY_CONSTANTS["scriptexecorder_normal"]
        if a in (_ATTR["scriptattribute_debuglevel"], _ATTR["customizationscriptattribute_activeduringsimulation"]):
            return 0 if a == _ATTR["scriptattribute_debuglevel"] else True
        raise ArgumentError(f"script attribute {a} is not supported")

    def handleChildScripts(self, callType: Any, *args: Any) -> int:  # noqa: N802, N803
        """V-REP's cascade of child scripts: simx runs every child script itself at every pass,
        so nothing is left to run here; returns 0 (child scripts run by this call)."""
        _int(callType, "callType")
        return 0

    handleSimulationScripts = handleChildScripts

    def delegateChildScriptExecution(self) -> int:  # noqa: N802
        """V-REP 3.0-3.2's ``simDelegateChildScriptExecution()``: a threaded child script hands
        the cascade of its descendants' non-threaded child scripts to the main script (it cannot
        run them from its own loop). simx runs every child script itself at every pass, with no
        cascade, so they already run as delegated: returns 1."""
        return 1

    def getInt32Parameter(self, parameter: Any) -> int | None:  # noqa: N802
        """V-REP 3.x's ``simGetIntegerParameter`` / ``simGetInt32Parameter``: as
        ``sim.getInt32Param``, except ``sim.intparam_flymode_camera_handle``, which answers nil:
        a headless server has no fly-mode camera, and V-REP's Lua answered nil where the call
        found none (scripts test ``if (flyModeCameraHandle) then``)."""
        if _int(parameter, "parameter") == C.sim_intparam_flymode_camera_handle:
            return None
        return self.getInt32Param(parameter)

    # ---------------------------------------------------------------- custom data blocks
    def _blocks(self, handle: Any) -> dict:
        h = self._h(handle)
        if h not in (HANDLE_SCENE, -1):
            self._world.get(h)
        me = getattr(self, "_script", None)
        store = me.shared.setdefault("custom_data", {}) if me is not None else {}
        return store.setdefault(h, {})

    def writeCustomDataBlock(self, objectHandle: Any, tagName: Any, data: Any) -> int:  # noqa: N802, N803
        """Store ``data`` (bytes) under ``tagName`` on an object (``sim.handle_scene``: the scene);
        empty data or nil removes the tag. Blocks live as long as the loaded scene."""
        blocks, tag = self._blocks(objectHandle), _text(tagName, "tagName")
        if data is None or data == b"" or data == "":
            blocks.pop(tag, None)
            return 1
        raw = _bytes(data, "data")
        if len(raw) > _MAX_CUSTOM_DATA:
            raise ArgumentError(f"custom data block {tag!r} of {len(raw)} bytes: at most {_MAX_CUSTOM_DATA}")
        blocks[tag] = raw
        return 1

    def readCustomDataBlock(self, objectHandle: Any, tagName: Any) -> bytes | None:  # noqa: N802, N803
        """The block stored under ``tagName``, nil when there is none."""
        return self._blocks(objectHandle).get(_text(tagName, "tagName"))

    def readCustomDataBlockTags(self, objectHandle: Any) -> list[str]:  # noqa: N802, N803
        """The tags of the object's custom data blocks."""
        return sorted(self._blocks(objectHandle))

    # ---------------------------------------------------------------- helpers
    def boolOr32(self, a: Any, b: Any) -> int:  # noqa: N802
        """``a | b`` on 32-bit unsigned values (3.x ``simBoolOr16`` too)."""
        return (_int(a, "value1") | _int(b, "value2")) & 0xFFFFFFFF

    def boolAnd32(self, a: Any, b: Any) -> int:  # noqa: N802
        """``a & b`` on 32-bit unsigned values (3.x ``simBoolAnd16`` too)."""
        return (_int(a, "value1") & _int(b, "value2")) & 0xFFFFFFFF

    def boolXor32(self, a: Any, b: Any) -> int:  # noqa: N802
        """``a ^ b`` on 32-bit unsigned values (3.x ``simBoolXor16`` too)."""
        return (_int(a, "value1") ^ _int(b, "value2")) & 0xFFFFFFFF

    def getSystemTimeInMs(self, previousTime: Any = -1) -> int:  # noqa: N802, N803
        """Milliseconds of a monotonic clock (``previousTime`` -1), or elapsed since ``previousTime``."""
        now = int(time.monotonic() * 1000) & 0x7FFFFFFF
        prev = _int(previousTime, "previousTime")
        return now if prev == -1 else (now - prev) & 0x7FFFFFFF

    # ---------------------------------------------------------------- remote API plugin
    def _ports(self) -> RemoteApiPorts:
        sim = self._simulation("remoteApiStart")
        ports = getattr(sim, "remote_api", None)
        if ports is None:
            raise ArgumentError("remoteApiStart needs a server (this simulation serves no remote API)")
        return ports

    def remoteApiStart(self, port: Any, maxPacketSize: Any = 1300, debug: Any = False,  # noqa: N802, N803
                       preEnableTrigger: Any = False) -> int:  # noqa: N803
        """``simExtRemoteApiStart(port)`` / ``simRemoteApi.start(port)``: serve the legacy remote
        API on ``port`` too (a no-op when it is served already: 19997/19999 by default); the
        server opens it on its own thread, under the same host and security configuration.
        Returns 1 (the port is served or will be)."""
        p = _int(port, "port")
        if not 1 <= p <= 65535:
            raise ArgumentError(f"port must be 1..65535, got {p}")
        self._ports().request(p)
        return 1

    def remoteApiStatus(self, port: Any) -> int:  # noqa: N802
        """1 when the legacy remote API is served on ``port`` (or about to be), else -1."""
        ports = self._ports()
        p = _int(port, "port")
        return 1 if p in ports.served or p in ports.pending else -1

    def remoteApiStop(self, port: Any) -> int:  # noqa: N802
        """Ports opened for the scene stay open while the server runs: logged, returns 0."""
        log.info("[%s] simRemoteApi.stop(%s): simx keeps serving the port", self._label, port)
        return 0

    def remoteApiReset(self) -> int:  # noqa: N802
        """Nothing to reset: returns 0."""
        return 0


def _parameter(script: Any, name: str, as_string: bool) -> Any:
    for p in getattr(script, "parameters", ()):
        if p.get("name") == name:
            value = p.get("value")
            if as_string:
                return "" if value is None else str(value)
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                return value
            text = str(value).strip()
            for cast in (int, float):
                try:
                    return cast(text)
                except ValueError:
                    pass
            return text
    return None
