"""The context every API function takes: the world it acts on, who calls, and that caller's stores.

A child script (Lua or Python) has one :class:`CallContext` for its life; a ZMQ door has one for
its clients, whose world is read from the simulation at each call (a scene load replaces it).
The API functions of :mod:`simx_server.api.sim` and :mod:`simx_server.api.simik` receive it as
their first argument, so what they read and keep is explicit here rather than spread over
attributes of one object.
"""

from __future__ import annotations

import dataclasses
import functools
import random
from collections.abc import Callable
from typing import Any

from simx_server.api.registry import SIM, SIMIK, SIMOMPL, SIMVISION, ApiFunction, ApiTable, Callers
from simx_server.api.signals import Signals
from simx_server.base.arguments import as_integer
from simx_server.sim.state import SimulationView
from simx_server.sim.world import World
from simx_wire import constants
from simx_wire.protocol import UnsupportedError

_HANDLE_SELF: int = constants.VREP_CONSTANTS["sim_handle_self"]
_HANDLE_PARENT: int = constants.VREP_CONSTANTS["sim_handle_parent"]


@dataclasses.dataclass
class CallerState:
    """What one caller keeps between its calls (a script's, or a ZMQ door's for its clients).

    Without a simulation behind the caller (a bare script in a test), the stores that normally
    live on the simulation (custom data, engine settings...) are kept here too: see
    :attr:`CallContext.holder`.
    """

    #: ``sim.getNameSuffix`` / ``setNameSuffix`` (V-REP 3.x): None until first read.
    name_suffix: int | None = None
    #: The caller's own shared stores (tubes, wireless, particles) when it is not a script.
    own_shared: dict[str, Any] = dataclasses.field(default_factory=dict)
    #: ``sim.getRandom``'s generator, made at its first call.
    rng: random.Random | None = None
    #: Ruckig objects by handle, and the last handle given.
    ruckig: dict[int, Any] | None = None
    ruckig_next: int | None = None
    #: Explicit-handling flags of objects (``sim.setExplicitHandling``).
    explicit: dict[int, int] | None = None
    #: Headless GUI handles given so far; auxiliary consoles by handle.
    gui_handles: int = 0
    consoles: dict[int, str] | None = None
    #: simIK environments by handle; the scratch MjData the solver uses, and its model.
    ik_environments: dict[int, Any] | None = None
    ik_scratch: Any = None
    ik_scratch_model: Any = None
    #: simOMPL state spaces and tasks by handle (:mod:`simx_server.api.simompl`).
    ompl: dict[str, Any] | None = None
    #: ``sim.setAutoYieldDelay``'s delay in ms (CoppeliaSim's default: 2 ms).
    auto_yield_delay_ms: int = 2


class CallContext:
    """The explicit context of an API call.

    Args:
        world: the scene (ignored where ``live`` is given).
        owner: handle of the caller's object (``sim.handle_self``); -1 for remote clients.
        signals: the server's signal store.
        label: how log lines name the caller.
        view: the simulation (sensors, the editor, the run state), or None for a bare script.
        forces: the forces scripts add for the next step.
        script: the child script that calls (its execution count, parameters, threads), or None.
        caller: :attr:`Callers.SCRIPTS` or :attr:`Callers.CLIENTS`.
        live: for remote clients, a function giving the simulation at each call (world and
            forces are then read from it).
    """

    def __init__(
        self,
        world: World | None,
        owner: int,
        signals: Signals | None = None,
        label: str = "",
        view: SimulationView | None = None,
        forces: Any = None,
        script: Any = None,
        caller: Callers = Callers.SCRIPTS,
        live: Callable[[], Any] | None = None,
    ):
        self._world_fixed = world
        self._live = live
        self.owner = owner
        self.signals = signals if signals is not None else Signals()
        self._view = view
        self._forces = forces
        self.script = script
        self.caller = caller
        self.state = CallerState()
        if not label and world is not None:
            label = world.get(owner).name
        self.label = label
        self._sim: ApiNamespace | None = None
        self._simik: ApiNamespace | None = None
        self._simompl: ApiNamespace | None = None
        self._simvision: ApiNamespace | None = None

    # ------------------------------------------------------------- what it acts on
    @property
    def world(self) -> World:
        """The scene (a remote client's: the simulation's current one)."""
        if self._live is not None:
            world: World = self._live().world
            return world
        assert self._world_fixed is not None
        return self._world_fixed

    @property
    def view(self) -> SimulationView | None:
        """The simulation behind the caller, or None (a bare script in a test)."""
        if self._live is not None:
            view: SimulationView = self._live()
            return view
        return self._view

    @property
    def forces(self) -> Any:
        """The forces scripts added for the next step (:class:`simx_server.api.sim.forces.AppliedForces`)."""
        if self._live is not None:
            return self._live().scripts.forces
        return self._forces

    @property
    def remote(self) -> bool:
        """Whether the caller is a remote API client (not a child script)."""
        return self.caller == Callers.CLIENTS

    @property
    def defer_renders(self) -> bool:
        """Image calls answer a Deferred for remote clients: the ZMQ service replies once the
        render thread is done; scripts wait for the frame."""
        return self.remote

    @property
    def holder(self) -> Any:
        """Where scene-wide stores live (custom data, engine settings...): the simulation, or this
        caller's :class:`CallerState` without one."""
        view = self.view
        return view if view is not None else self.state

    @property
    def sim(self) -> ApiNamespace:
        """``sim`` bound to this context: ``ctx.sim.getObjectPose(h, -1)`` calls through the table."""
        if self._sim is None:
            self._sim = ApiNamespace(SIM, self)
        return self._sim

    @property
    def simik(self) -> ApiNamespace:
        """``simIK`` bound to this context."""
        if self._simik is None:
            self._simik = ApiNamespace(SIMIK, self)
        return self._simik

    @property
    def simompl(self) -> ApiNamespace:
        """``simOMPL`` bound to this context."""
        if self._simompl is None:
            self._simompl = ApiNamespace(SIMOMPL, self)
        return self._simompl

    @property
    def simvision(self) -> ApiNamespace:
        """``simVision`` bound to this context."""
        if self._simvision is None:
            self._simvision = ApiNamespace(SIMVISION, self)
        return self._simvision

    def simulation(self, what: str) -> SimulationView:
        """The simulation, for the call ``what``; UnsupportedError naming it without one."""
        view = self.view
        if view is None:
            raise UnsupportedError(f"sim.{what} needs the simulation: this script runs without one")
        return view

    # ------------------------------------------------------------------ handles
    def h(self, handle: Any, what: str = "object handle") -> int:
        """An object argument as a handle: an int (``sim.handle_self`` is the caller's object), or
        any form ``sim.getObject`` takes (CoppeliaSim 4.3+ accepts an object path wherever a
        handle goes): a name (``arm``, 3.x's ``arm#0``), a path (``/UR5/joint``, ``./arm``,
        ``:``, ``/arm[1]``), or ``{"path": ..., "index": n}``.

        Raises:
            ArgumentError: not an integer, a path or such a map.
            UnknownObjectError: a path that names no object.
        """
        if type(handle) is int:  # the usual case, first
            return self.owner if handle == _HANDLE_SELF else handle
        if isinstance(handle, (str, bytes)):
            return int(self.sim.getObject(handle))
        if isinstance(handle, dict) and "path" in handle:
            options = {k: v for k, v in handle.items() if k != "path"}
            return int(self.sim.getObject(handle["path"], options))
        h = as_integer(handle, what)
        return self.owner if h == _HANDLE_SELF else h

    def rel(self, relative_to: Any) -> int:
        """A ``relativeToObjectHandle`` argument: -1 (the world), ``sim.handle_parent``, or an object.

        Raises:
            UnknownObjectError: no such object.
        """
        rel = self.h(relative_to, "relativeToObjectHandle")
        if rel not in (-1, _HANDLE_PARENT):
            self.world.get(rel)
        return rel

    def path_base(self) -> int | None:
        """The object relative paths (``./x``, ``:``) start from: the script's; None for a remote
        client (unassociated code)."""
        return None if self.remote else self.owner


class ApiNamespace:
    """One library of the table (``sim`` or ``simIK``) bound to a :class:`CallContext`.

    Args:
        table: the library's table (its functions and constants).
        ctx: the caller's context.
    """

    def __init__(self, table: ApiTable, ctx: CallContext):
        self._table = table
        self._constants = table.constants
        self.context = ctx
        self._allowed: dict[str, Callable[..., Any]] = {}  # names this caller may call: their functions

    def entry(self, name: str) -> ApiFunction:
        """The table entry of ``name`` that this caller may call.

        Raises:
            AttributeError: no such function (nor constant).
            UnsupportedError: a function served to the other kind of caller only.
        """
        entry = self._table.get(name)
        if entry is None:
            raise AttributeError(
                f"{self._table.library}.{name} is not available in simx "
                "(docs/SCRIPTS.md and docs/COVERAGE.md list what is)"
            )
        if not entry.callers & self.context.caller:
            who = "remote API clients" if entry.callers == Callers.CLIENTS else "child scripts"
            raise UnsupportedError(f"{entry.qualified} is served to {who} only in simx")
        return entry

    def call(self, name: str, *args: Any) -> Any:
        """Call ``name`` with ``args`` in this context (errors as :meth:`entry`, then the function's)."""
        function = self._allowed.get(name)
        if function is None:  # looked up and checked once per name (the table is filled at import)
            function = self._allowed[name] = self.entry(name).function
        return function(self.context, *args)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        if name in self._table:  # who may call it is checked at the call (getattr never fails)
            return functools.partial(self.call, name)
        if name in self._constants:
            return self._constants[name]
        self.entry(name)  # raises AttributeError naming the call
        raise AssertionError(name)  # pragma: no cover

    def __dir__(self) -> list[str]:
        return sorted({*self._table.names(self.context.caller), *self._constants})
