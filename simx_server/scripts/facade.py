"""The whole ``sim`` facade of child scripts: V-REP 3.x's core and CoppeliaSim 4.x's calls.

:class:`ScriptSim` composes :class:`~simx_server.scripts.facade_core.SimFacade` (objects, joints,
poses, time, signals, messages, packing: the V-REP 3.x calls), :class:`ObjectCalls`
(:mod:`simx_server.scripts.facade_objects`: tree, matrices, velocities, forces, scene edits),
:class:`SensorCalls` (:mod:`simx_server.scripts.facade_sensors`: 4.x signal names, sensors, object
parameters, simulation state) and CoppeliaSim 4.x's regular API by concern (one module
each: parameters, window functions answered headless, shapes, collision and sensing, data and
properties, paths and collections, engine parameters, images and saving, meshes, Ruckig). The
same object serves ZMQ clients (:class:`simx_server.zmq.remote_sim.RemoteSim`); docs/COVERAGE.md
lists every function. Python scripts get one as ``sim``; Lua scripts get one Lua
function per :data:`FACADE_FUNCTIONS` entry and every :data:`FACADE_CONSTANTS` entry as
``sim.NAME`` (:mod:`simx_server.scripts.lua`). docs/SCRIPTS.md lists them all.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from simx_wire.protocol import UnsupportedError
from simx_server.scripts import facade_legacy, facade_objects, facade_sensors
from simx_server.scripts.facade_build import BuildCalls
from simx_server.scripts.facade_clouds import CloudCalls
from simx_server.scripts.facade_octrees import OctreeCalls
from simx_server.scripts.facade_common import CommonCalls
from simx_server.scripts.facade_create import CreateCalls
from simx_server.scripts.facade_data import DataCalls
from simx_server.scripts.facade_engine import EngineCalls
from simx_server.scripts.facade_flags import FlagCalls
from simx_server.scripts.facade_graphs import GraphCalls
from simx_server.scripts.facade_gui import GuiCalls
from simx_server.scripts.facade_links import LinkCalls
from simx_server.scripts.facade_looks import LookCalls
from simx_server.scripts.facade_mesh import MeshCalls
from simx_server.scripts.facade_motion import ScriptMotionCalls
from simx_server.scripts.facade_meshops import MeshOpCalls
from simx_server.scripts.facade_misc import MiscCalls
from simx_server.scripts.facade_params import ParamCalls
from simx_server.scripts.facade_particles import ParticleCalls
from simx_server.scripts.facade_paths import PathCalls
from simx_server.scripts.facade_posemath import PoseMath
from simx_server.scripts.facade_props import PropertyCalls
from simx_server.scripts.facade_ruckig import RuckigCalls
from simx_server.scripts.facade_sensing import SensingCalls
from simx_server.scripts.facade_joint_modes import JointModeCalls
from simx_server.scripts.facade_services import ServiceCalls
from simx_server.scripts.facade_shapes import ShapeCalls
from simx_server.scripts.facade_inertia import InertiaCalls
from simx_server.scripts.facade_trajectory import TrajectoryCalls
from simx_server.scripts.facade_legacy import LegacyCalls
from simx_server.scripts.facade_core import SCRIPT_CONSTANTS, SimFacade
from simx_server.scripts.signals import Signals
from simx_server.scripts.facade_objects import AppliedForces, ObjectCalls
from simx_server.scripts.facade_sensors import SensorCalls
from simx_server.sim.state import SimulationView
from simx_server.sim.world import World

#: CoppeliaSim 4.x's ``sim`` constants (``sim.primitiveshape_cuboid``, ``sim.intparam_program_version``...),
#: from the table the ZMQ remote API ships (``simx_server/zmq/coppeliasim_api.json``, data read here).
_COPPELIASIM_4 = json.loads((Path(__file__).resolve().parents[1] / "zmq" / "coppeliasim_api.json").read_text(
    encoding="utf-8"))["constants"]["sim"]
#: Every ``sim.NAME`` constant of child scripts: the legacy ``sim_*`` constants, ``handle_world``,
#: CoppeliaSim's that simx adds (``handle_scene``, ``handleflag_greyscale``, ``simulation_*``), then
#: CoppeliaSim 4.x's others (where both name one, the legacy value wins: simx's calls read it).
FACADE_CONSTANTS: dict[str, int] = {**_COPPELIASIM_4, **SCRIPT_CONSTANTS, **facade_objects.CONSTANTS,
                                    **facade_sensors.CONSTANTS, **facade_legacy.CONSTANTS}


class ScriptSim(CloudCalls, OctreeCalls, ServiceCalls, FlagCalls, CreateCalls, MeshOpCalls, LookCalls, TrajectoryCalls, BuildCalls,
                GraphCalls, LinkCalls, ParticleCalls, PoseMath, CommonCalls, ParamCalls, GuiCalls, RuckigCalls, MeshCalls, MiscCalls, EngineCalls, PathCalls, PropertyCalls,
                DataCalls, ScriptMotionCalls,
                ShapeCalls, InertiaCalls, SensingCalls, JointModeCalls, ObjectCalls, SensorCalls, LegacyCalls,
                SimFacade):
    """``sim`` of one child script: every call of docs/SCRIPTS.md.

    Args:
        world: the scene.
        owner: handle of the script's object (``sim.handle_self``).
        signals: the server's signal store.
        label: how log lines name the script.
        simulation: the :class:`~simx_server.scene.simulation.Simulation` (sensors, the scene editor,
            the run state); without one (a bare :class:`~simx_server.scripts.scene_scripts.Scripts` in a
            test) the calls that need it raise UnsupportedError naming themselves.
        forces: the forces scripts added for the next step (one per Scripts).
    """

    def __init__(self, world: World, owner: int, signals: Signals | None = None, label: str = "",
                 simulation: SimulationView | None = None, forces: AppliedForces | None = None):
        super().__init__(world, owner, signals, label)
        self._sim = simulation
        self._forces = forces if forces is not None else AppliedForces()

    def __getattr__(self, name: str) -> Any:
        if name in FACADE_CONSTANTS:
            return FACADE_CONSTANTS[name]
        return super().__getattr__(name)

    def _simulation(self, what: str) -> SimulationView:
        if self._sim is None:
            raise UnsupportedError(f"sim.{what} needs the simulation: this script runs without one")
        return self._sim


def _functions(cls: type) -> tuple[str, ...]:
    names = set()
    for klass in cls.__mro__[:-1]:  # not object's
        names.update(n for n, v in vars(klass).items() if not n.startswith("_") and callable(v))
    return tuple(sorted(names))


#: Names of the facade's functions (``sim.NAME`` in both languages).
FACADE_FUNCTIONS: tuple[str, ...] = _functions(ScriptSim)
