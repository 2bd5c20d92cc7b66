"""CoppeliaSim's ``sim`` API: one module per category, each function registered once by name.

Importing this package registers every ``sim.NAME`` in :data:`simx_server.api.registry.SIM`
and fills its constants (:data:`CONSTANTS`). The categories, as CoppeliaSim's API reference
groups them: objects and the scene tree (:mod:`.core`, :mod:`.objects`, :mod:`.common`,
:mod:`.flags`, :mod:`.props`, :mod:`.data`), joints (:mod:`.joints`, :mod:`.joint_modes`),
shapes and meshes (:mod:`.shapes`, :mod:`.shape_import`, :mod:`.mesh`, :mod:`.meshops`, :mod:`.decompose`,
:mod:`.inertia`, :mod:`.looks`, :mod:`.build`), sensors (:mod:`.sensors`, :mod:`.sensing`,
:mod:`.create`), point clouds and octrees (:mod:`.clouds`, :mod:`.octrees`), paths and motion
(:mod:`.paths`, :mod:`.trajectory`, :mod:`.ruckig`, :mod:`.motion`, :mod:`.stepped`),
pose arithmetic (:mod:`.posemath`, :mod:`.rotations`), simulation and parameters
(:mod:`.params`, :mod:`.engine`, :mod:`.remote`), drawing, graphs and particles
(:mod:`.links`, :mod:`.graphs`, :mod:`.particles`), windows answered headless (:mod:`.gui`),
files and services (:mod:`.misc`, :mod:`.services`), threads (:mod:`.threads`), and V-REP 3.x's
calls (:mod:`.legacy` and the ``legacy_*`` modules, configuration trees in :mod:`.legacy_config`).
"""

from __future__ import annotations

import json
from pathlib import Path

from simx_server.api.registry import SIM
from simx_server.api.sim import (  # noqa: F401 (each module registers its functions)
    build, clouds, common, core, create, data, decompose, engine, flags, forces, graphs, gui, ik_groups, inertia,
    joint_modes, joints, legacy, legacy_config, legacy_data, legacy_measurements, legacy_objects, legacy_paths,
    legacy_tubes, legacy_wireless, links, looks, mesh, meshops, misc, motion, objects, octrees, params, particles,
    paths, posemath, props, remote, rotations, ruckig, scripting, sensing, sensors, services, shape_import,
    shape_texture, shapes, stepped, threads, trajectory)

#: CoppeliaSim 4.x's ``sim`` constants (``sim.primitiveshape_cuboid``, ``sim.intparam_program_version``...),
#: from the table the ZMQ remote API ships (``simx_server/zmq/coppeliasim_api.json``, data read here).
_COPPELIASIM_4 = json.loads((Path(__file__).resolve().parents[2] / "zmq" / "coppeliasim_api.json").read_text(
    encoding="utf-8"))["constants"]["sim"]
#: Every ``sim.NAME`` constant: the legacy ``sim_*`` constants, ``handle_world``, CoppeliaSim's
#: that simx adds (``handle_scene``, ``handleflag_greyscale``, ``simulation_*``), then CoppeliaSim
#: 4.x's others (where both name one, the legacy value wins: simx's calls read it).
CONSTANTS: dict[str, int] = {**_COPPELIASIM_4, **core.SCRIPT_CONSTANTS, **objects.CONSTANTS,
                             **sensors.CONSTANTS, **legacy.CONSTANTS}
SIM.constants.update(CONSTANTS)

#: Names of every ``sim`` function (``sim.NAME`` in both languages and over ZMQ).
FUNCTIONS: tuple[str, ...] = SIM.names()
