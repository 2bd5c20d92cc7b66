"""One definition per ``sim`` name, and ``sim.getObjectHandle`` taking every form ``sim.getObject``
takes (issue 43).

The facade was once assembled from mixins, and a name defined in two of them was silently
shadowed by the earlier one in its method resolution order (``getObjectHandle`` took fewer path
forms than ``getObject``: ``sim.getObjectHandle('./lumibot_leftMotor')`` answered "does not
exist" where ``sim.getObject`` found it). The scene here: two copies of a small model, V-REP's
way (``robot`` and ``robot#0``, each with an ``arm`` that shares the alias ``arm``).
"""

from __future__ import annotations

import pytest

from simx_wire import constants as C
from simx_wire.protocol import UnknownObjectError
from simx_server.scene.simulation import Simulation
from simx_server.api import client_context, script_sim
from simx_server.api.registry import ApiTable, DuplicateApiNameError

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
MODEL_COPIES = """
<mujoco model="copies">
  <worldbody>
    <body name="robot" pos="0 0 0.1">
      <geom type="box" size="0.05 0.05 0.05"/>
      <body name="arm" pos="0.1 0 0"><geom type="box" size="0.02 0.02 0.02"/></body>
    </body>
    <body name="robot#0" pos="1 0 0.1">
      <geom type="box" size="0.05 0.05 0.05"/>
      <body name="arm#0" pos="0.1 0 0"><geom type="box" size="0.02 0.02 0.02"/></body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_name_registered_twice_is_an_error():
    """The table refuses a second definition of a name, naming both (at import, for a module)."""
    table = ApiTable("sim")

    def first(ctx): ...

    def second(ctx): ...

    table.register("getObject", first)
    with pytest.raises(DuplicateApiNameError, match=r"sim\.getObject is registered twice.*first.*second"):
        table.register("getObject", second)
    assert table["getObject"].function is first


@pytest.fixture
def sim(tmp_path):
    scene = tmp_path / "copies.xml"
    scene.write_text(MODEL_COPIES)
    s = Simulation(scene, realtime=False)
    yield s
    s.close()


def handle(sim, name: str) -> int:
    return sim.world.resolve(name).handle


def test_get_object_handle_takes_every_form_get_object_takes(sim):
    """In the script of the copy ``robot#0``: paths, indices, aliases, ``:`` and ``noError`` as
    ``sim.getObject``; bare names with the script's automatic suffix, as V-REP 3.x."""
    api = script_sim(sim.world, handle(sim, "robot#0"), sim.signals, simulation=sim)
    arm, arm0, robot0 = handle(sim, "arm"), handle(sim, "arm#0"), handle(sim, "robot#0")
    for path, options in [("./arm", None), ("/robot/arm", None), ("/arm", {"index": 1}), (":", None),
                          (":/arm", None), ("/arm[1]", None), (".", None), ("arm#0", None), ("arm#", None)]:
        assert api.getObjectHandle(path, options) == api.getObject(path, options), (path, options)
    assert api.getObjectHandle("./arm") == arm0
    assert api.getObjectHandle(":") == robot0
    assert api.getObjectHandle("/arm", {"index": 0}) == arm
    assert api.getObjectHandle("arm") == arm0  # 3.x: the name of the script's own copy
    assert api.getObject("arm") == arm  # 4.x: a bare name is the name itself
    assert api.getObjectHandle("arm#") == arm  # "#": no suffix
    assert api.getObjectHandle(C.sim_handle_self) == robot0
    assert api.getObjectHandle("/nothing", {"noError": True}) == -1
    with pytest.raises(UnknownObjectError, match="'/nothing' does not exist"):
        api.getObjectHandle("/nothing")


def test_remote_get_object_handle_finds_what_get_object_finds(sim):
    """A remote program (ZMQ) has no object: ``./x`` starts from the scene root, for both calls."""
    remote = client_context(sim).sim
    for path in ("./arm", "/robot/arm", "arm", "robot#0", "/arm[1]"):
        assert remote.getObjectHandle(path) == remote.getObject(path), path
    assert remote.getObjectHandle("./arm") == handle(sim, "arm")


def test_the_4_1_double_signal_names_reach_the_float_signals(sim):
    """CoppeliaSim 4.1-4.4's ``sim.*DoubleSignal`` (the 4.4 ZMQ client's ``waitForSignal`` calls
    ``getDoubleSignal``) read and write the store of ``sim.*FloatSignal``."""
    remote = client_context(sim).sim
    remote.setDoubleSignal("level", 2.5)
    assert remote.getFloatSignal("level") == 2.5 and remote.getDoubleSignal("level") == 2.5
    remote.clearDoubleSignal("level")
    assert remote.getFloatSignal("level") is None
