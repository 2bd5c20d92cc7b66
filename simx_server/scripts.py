"""Child scripts attached to scene objects, and the ``sim`` facade they call.

A scene attaches a script to an object with ``<custom><text name="simx:OBJECT"
data="child_script=file.py"/></custom>``; the file lies next to the scene (scripts come
only from the server's disk). Python child scripts see a global ``sim`` (a :class:`SimFacade`)
and may define V-REP's life-cycle functions: ``sysCall_init`` (simulation start),
``sysCall_actuation`` and ``sysCall_sensing`` (every step), ``sysCall_cleanup`` (stop). Any
other global function can be called remotely with ``simxCallScriptFunction``: it receives
``(inInts, inFloats, inStrings, inBuffer)`` and returns up to four values
``(ints, floats, strings, buffer)``.
"""

from __future__ import annotations

import logging
import traceback
from pathlib import Path
from typing import Any, Callable

from simx_client import constants as C
from simx_client.protocol import ArgumentError, ScriptError, UnknownObjectError
from simx_server.world import World

log = logging.getLogger("simx.scripts")

LIFE_CYCLE = ("sysCall_init", "sysCall_actuation", "sysCall_sensing", "sysCall_cleanup")


class SimFacade:
    """V-REP's ``sim`` API for child scripts, on top of the world (names and units as V-REP's).

    Errors raise the simx exceptions (UnknownObjectError, ObjectTypeError, ArgumentError).
    """

    handle_self = C.sim_handle_self
    handle_parent = C.sim_handle_parent
    handle_world = -1

    def __init__(self, world: World, owner: int):
        self._world = world
        self._owner = owner

    def _h(self, handle: int) -> int:
        return self._owner if handle == C.sim_handle_self else int(handle)

    def getObjectHandle(self, name: str) -> int:  # noqa: N802 (V-REP's names)
        """Handle of the object called ``name``."""
        return self._world.resolve(name).handle

    def getObjectName(self, handle: int) -> str:  # noqa: N802
        """Name of the object ``handle``."""
        return self._world.get(self._h(handle)).name

    def getJointPosition(self, handle: int) -> float:  # noqa: N802
        """Joint position (rad or m)."""
        return self._world.joint_position(self._h(handle))

    def setJointTargetPosition(self, handle: int, position: float) -> None:  # noqa: N802
        """Target position of a position-controlled joint (rad or m)."""
        self._world.set_joint_target_position(self._h(handle), position)

    def setJointTargetVelocity(self, handle: int, velocity: float) -> None:  # noqa: N802
        """Target velocity of a velocity-mode joint (rad/s or m/s)."""
        self._world.set_joint_target_velocity(self._h(handle), velocity)

    def setJointForce(self, handle: int, force: float) -> None:  # noqa: N802
        """Maximum force/torque of the joint's motor (N or N·m)."""
        self._world.set_joint_force(self._h(handle), force)

    setJointMaxForce = setJointForce  # noqa: N815 (CoppeliaSim 4 name)

    def getJointForce(self, handle: int) -> float:  # noqa: N802
        """Force/torque the joint's motor applies (N or N·m)."""
        return self._world.joint_force(self._h(handle))

    def getSimulationTime(self) -> float:  # noqa: N802
        """Simulation time (s)."""
        return self._world.time

    def getSimulationTimeStep(self) -> float:  # noqa: N802
        """Simulation step dt (s)."""
        return self._world.dt

    def addStatusbarMessage(self, message: str) -> None:  # noqa: N802
        """Write ``message`` to the server log."""
        log.info("[%s] %s", self._world.get(self._owner).name, message)


class ChildScript:
    """One Python child script, loaded from ``path`` and attached to object ``owner``."""

    def __init__(self, world: World, owner: int, path: Path):
        self.owner = owner
        self.path = path
        self.name = world.get(owner).name
        try:
            source = path.read_text()
            self._code = compile(source, str(path), "exec")
        except (OSError, SyntaxError) as exc:
            raise ScriptError(f"child script of {self.name!r} ({path}): {exc}") from exc
        self._world = world
        self.namespace: dict[str, Any] = {}

    def start(self) -> None:
        """Fresh globals, run the file's top level, then ``sysCall_init``."""
        self.namespace = {"sim": SimFacade(self._world, self.owner), "__name__": f"simx_script_{self.name}"}
        self._guard("<top level>", lambda: exec(self._code, self.namespace))
        self.life_cycle("sysCall_init")

    def life_cycle(self, function: str) -> None:
        """Run a life-cycle function if the script defines it."""
        fn = self.namespace.get(function)
        if callable(fn):
            self._guard(function, fn)

    def call(self, function: str, ints: list, floats: list, strings: list, buffer: bytes) -> list:
        """Call a script function remotely; returns ``[ints, floats, strings, buffer]``."""
        fn = self.namespace.get(function)
        if function.startswith("_") or not callable(fn):
            raise ScriptError(f"child script of {self.name!r} has no function {function!r}")
        out = self._guard(function, lambda: fn(ints, floats, strings, buffer))
        return _legacy_outputs(out, f"{self.name}.{function}")

    def _guard(self, what: str, fn: Callable[[], Any]) -> Any:
        try:
            return fn()
        except Exception as exc:
            frame = traceback.extract_tb(exc.__traceback__)[-1]
            raise ScriptError(
                f"child script of {self.name!r}, {what}: {type(exc).__name__}: {exc} "
                f"({Path(frame.filename).name}:{frame.lineno})"
            ) from exc


def _legacy_outputs(out: Any, where: str) -> list:
    values = list(out) if isinstance(out, (tuple, list)) else ([] if out is None else [out])
    if len(values) > 4:
        raise ScriptError(f"{where} returned {len(values)} values; at most 4 (ints, floats, strings, buffer)")
    values += [[], [], [], b""][len(values):]
    ints, floats, strings, buf = values
    try:
        ints = [int(v) for v in ints]
        floats = [float(v) for v in floats]
        strings = [str(v) for v in strings]
        buf = buf.encode() if isinstance(buf, str) else bytes(buf)
    except (TypeError, ValueError) as exc:
        raise ScriptError(f"{where} returned values of the wrong types: {exc}") from exc
    return [ints, floats, strings, buf]


class Scripts:
    """Every child script of the scene, driven through the simulation life cycle."""

    def __init__(self, world: World):
        self.world = world
        self.scripts: dict[int, ChildScript] = {}
        for obj in world.objects.values():
            file = obj.settings.get("child_script")
            if file:
                path = (world.scene_path.parent / file).resolve()
                if world.scene_path.parent not in path.parents:
                    raise ValueError(f"child script {file!r} of {obj.name!r} lies outside the scene folder")
                self.scripts[obj.handle] = ChildScript(world, obj.handle, path)

    def _each(self, action: Callable[[ChildScript], None]) -> None:
        for script in self.scripts.values():
            try:
                action(script)
            except ScriptError as exc:
                log.error("%s", exc)

    def start(self) -> None:
        """Simulation starts: every script runs its top level and ``sysCall_init``."""
        self._each(ChildScript.start)

    def actuation(self) -> None:
        """Before a step: ``sysCall_actuation`` of every script."""
        self._each(lambda s: s.life_cycle("sysCall_actuation"))

    def sensing(self) -> None:
        """After a step: ``sysCall_sensing`` of every script."""
        self._each(lambda s: s.life_cycle("sysCall_sensing"))

    def stop(self) -> None:
        """Simulation stops: ``sysCall_cleanup`` of every script."""
        self._each(lambda s: s.life_cycle("sysCall_cleanup"))

    def call(self, object_name: str, script_type: int, function: str, ints, floats, strings, buffer) -> list:
        """``simxCallScriptFunction`` on the child script of ``object_name``."""
        if script_type != C.sim_scripttype_childscript:
            raise ScriptError(f"script type {script_type} is not supported; only child scripts "
                              f"(sim_scripttype_childscript = {C.sim_scripttype_childscript})")
        try:
            obj = self.world.resolve(object_name)
        except UnknownObjectError as exc:
            raise ScriptError(f"no child script: {exc}") from None
        script = self.scripts.get(obj.handle)
        if script is None:
            raise ScriptError(f"object {obj.name!r} has no child script")
        if not (isinstance(ints, list) and isinstance(floats, list) and isinstance(strings, list)
                and isinstance(buffer, bytes)):
            raise ArgumentError("script arguments must be lists of ints, floats, strings and bytes")
        return script.call(function, ints, floats, strings, buffer)
