"""CoppeliaSim's API as one table of plain functions (:mod:`.registry`), served alike to Lua and
Python child scripts and ZMQ clients: ``sim`` in :mod:`.sim`, ``simIK`` in :mod:`.simik`,
``simOMPL`` in :mod:`.simompl`, ``simVision`` in :mod:`.simvision`, the context every call takes in
:mod:`.context`."""

from __future__ import annotations

from typing import Any

from simx_server.api import sim as _sim, simik as _simik, simompl as _simompl  # noqa: F401 (importing them fills the tables)
from simx_server.api import simvision as _simvision  # noqa: F401
from simx_server.api.context import ApiNamespace, CallContext
from simx_server.api.registry import SIM, SIMIK, SIMOMPL, SIMVISION, Callers
from simx_server.api.signals import Signals
from simx_server.api.sim.forces import AppliedForces
from simx_server.sim.objects import WORLD
from simx_server.sim.state import SimulationView
from simx_server.sim.world import World

__all__ = ["SIM", "SIMIK", "SIMOMPL", "SIMVISION", "ApiNamespace", "CallContext", "Callers", "client_context", "script_sim"]


def script_sim(world: World, owner: int, signals: Signals | None = None, label: str = "",
               simulation: SimulationView | None = None, forces: AppliedForces | None = None,
               script: Any = None) -> ApiNamespace:
    """``sim`` of a child script (what a Python script gets as ``sim``; Lua calls the same).

    Args:
        world: the scene.
        owner: handle of the script's object (``sim.handle_self``).
        signals: the server's signal store (a new one if None).
        label: how log lines name the script (default: the object's name).
        simulation: the simulation (sensors, the scene editor, the run state); without one the
            calls that need it raise UnsupportedError naming themselves.
        forces: the forces scripts added for the next step (one per scene's scripts).
        script: the child script itself (its execution count, parameters, threads), or None.

    Returns:
        The namespace; its ``context`` is the script's :class:`CallContext`.
    """
    ctx = CallContext(world, owner, signals, label, view=simulation,
                      forces=forces if forces is not None else AppliedForces(), script=script)
    return ctx.sim


def client_context(simulation: Any, label: str = "zmq") -> CallContext:
    """The context of remote API clients over ``simulation`` (its world and forces read at each call).

    Args:
        simulation: the server's :class:`~simx_server.scene.simulation.Simulation`.
        label: how log lines name the callers.
    """
    return CallContext(None, WORLD, simulation.signals, label, caller=Callers.CLIENTS, live=lambda: simulation)
