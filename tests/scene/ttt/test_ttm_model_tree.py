"""A V-REP model (``.ttm``) shaped as RLBench's task models (issue 51): its root is a dummy, the
model base, and its shapes become bodies of the world hung from it by ``vrep_parent=`` (a dynamic
one free, a joint's two children in an unnamed body that carries the joint). Loaded in process
(as PyRep's ``import_model`` and a scene script's ``sim.loadModel`` load it), the load returns
that dummy; the model's old path and custom data come from its conversion's folder; removing the
model leaves the scene as it was, and loading it again gives the same names (no ``#n``)."""

from __future__ import annotations

import pytest

import tttwriter as W
from test_ttt_kinds import CORNER, old_path
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation
from simx_server.sim.world import DUMMY

pytestmark = pytest.mark.renderers_on_demand

FLOOR = b'<mujoco><worldbody><geom type="plane" size="2 2 0.1"/></worldbody></mujoco>'


def task_model() -> bytes:
    return W.ttt_file(
        W.dummy(1, -1, "Task", (0, 0, 0.3), extra=W.model_base()) +
        W.cuboid_shape(2, 1, "Block", (0.05, 0.05, 0.05), (0.2, 0, 0.1)) +  # dynamic: a free body
        W.cuboid_shape(3, 1, "Stand", (0.2, 0.2, 0.02), (0, 0, -0.2), dynamic=False) +
        W.joint(4, 1, "Lever_joint", (-0.3, 0, 0)) +
        W.cuboid_shape(5, 4, "Lever_a", (0.02, 0.02, 0.1), (0, 0, 0.05)) +
        W.cuboid_shape(6, 4, "Lever_b", (0.02, 0.02, 0.1), (0, 0, -0.05)) +
        W.dummy(7, 1, "Waypoint", (0, 0, 0.1), extra=W.custom_data_3x({"task": b"reach"})) +
        old_path(8, 1, "Track", CORNER, 1 | 2 | 128, pos=(0, 0, 0.1)), serialization=24, program=40100)


@pytest.fixture
def sim(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (tmp_path / "floor.xml").write_bytes(FLOOR)
    (tmp_path / "task.ttm").write_bytes(task_model())
    s = Simulation(tmp_path / "floor.xml", dt=0.05, realtime=False)
    yield s
    s.close()


def counts(sim) -> tuple:
    m = sim.world.model
    return (m.nbody, m.njnt, m.ngeom, m.nsite, m.nmesh, m.nmeshface, m.ntex, m.nmat, m.ntext, m.nu, m.neq,
            m.nexclude, len(sim.editor._live_spec().assets or {}), len(sim.world.objects))


def test_a_task_model_loads_as_its_dummy_and_goes_whole(sim, tmp_path):
    w = sim.world
    empty = counts(sim)
    for _ in range(2):  # the second load after a removal: the same names, nothing left behind
        base = sim.editor.load_model(str(tmp_path / "task.ttm"), 0)
        task = w.get(base)
        assert (task.name, task.type) == ("Task", DUMMY)
        api = script_sim(w, base, sim.signals, simulation=sim)
        assert api.getModelProperty(base) == 0  # a model base
        for name in ("Block", "Stand", "Lever_joint", "Waypoint", "Track"):
            assert w.resolve(name).parent == base, name
        assert w.resolve("Lever_a").parent == w.resolve("Lever_joint").handle
        # what the model's files hold: its path's points, its dummy's custom data
        assert api.getPathLength(w.resolve("Track").handle) > 1.9
        assert api.readCustomDataBlockEx(w.resolve("Waypoint").handle, "task") == b"reach"
        sim.start()
        for _ in range(3):
            sim.step()
        sim.stop()
        assert api.removeModel(base) == 8
        assert counts(sim) == empty
        assert not any(n.startswith(("Task", "Block", "Lever")) for n in w.by_name)
