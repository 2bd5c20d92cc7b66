"""Scripts that models bring (``simxLoadModel``, ``sim.loadModel``) and copies get
(``simxCopyPasteObjects``) run as the scene's own, as in CoppeliaSim: a customization script at
once, a child script with the next start or, while the simulation runs, in its next pass
(``sysCall_init`` first); a removed model's end (``sysCall_cleanup``). A client's model (its
transfer folder) brings them only with ``--allow-remote-code`` (docs/SECURITY.md). In process
(``Simulation``) with MJCF models; tests/scene/ttt/test_ttm_model_scripts.py has ``.ttm`` models
on real servers."""

from __future__ import annotations

import logging

import pytest

from conftest import SCENE
from simx_server.commands.editing import EDITING_HANDLERS as H
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand

#: A crate on a hinge, a child script on its body and a customization script on its joint.
CRATE = """<mujoco model="crate">
  <worldbody>
    <body name="Crate" pos="0.6 0.6 0.3">
      <joint name="Crate_joint" type="hinge" axis="0 0 1"/>
      <geom name="Crate_geom" type="box" size="0.05 0.05 0.05" mass="0.3"/>
    </body>
  </worldbody>
  <custom>
    <text name="simx:Crate" data="child_script=crate.lua note=kept"/>
    <text name="simx:Crate_joint" data="customization_script=crate_custom.lua"/>
  </custom>
</mujoco>
"""

#: The child script: counts its inits and cleanups, notes the joint its V-REP 3.x lookup finds
#: (the name suffix of its own object: ``Crate#0`` finds ``Crate_joint#0``) and the order of its
#: calls in the pass.
CHILD = """
local function add(name) sim.setInt32Signal(name, (sim.getInt32Signal(name) or 0) + 1) end
function sysCall_init()
  add('inits')
  sim.setInt32Signal('joint_of_' .. sim.getObjectHandle(sim.handle_self), sim.getObjectHandle('Crate_joint'))
  sim.setStringSignal('calls', (sim.getStringSignal('calls') or '') .. 'i')
end
function sysCall_actuation()
  sim.setStringSignal('calls', (sim.getStringSignal('calls') or '') .. 'a')
end
function sysCall_cleanup() add('cleanups') end
"""

CUSTOM = """
local function add(name) sim.setInt32Signal(name, (sim.getInt32Signal(name) or 0) + 1) end
function sysCall_init() add('custom_inits') end
function sysCall_cleanup() add('custom_cleanups') end
"""


def _write_model(folder):
    folder.mkdir(exist_ok=True)
    (folder / "crate.xml").write_text(CRATE)
    (folder / "crate.lua").write_text(CHILD)
    (folder / "crate_custom.lua").write_text(CUSTOM)
    return folder / "crate.xml"


@pytest.fixture
def trusted(tmp_path):
    model = _write_model(tmp_path / "models")
    sim = Simulation(SCENE, dt=0.05, realtime=False, scene_paths=[model.parent])
    yield sim, model
    sim.close()


def _int(sim, name):
    return sim.signals.get_int(name)


def test_a_trusted_model_runs_its_scripts_as_the_scenes_own(trusted):
    sim, model = trusted
    w = sim.world
    base = H["LoadModel"](sim, [str(model), 0])
    assert w.get(base).name == "Crate"
    assert _int(sim, "custom_inits") == 1  # a customization script: at once
    assert _int(sim, "inits") is None  # a child script: with the simulation
    assert w.get(base).settings == {"note": "kept", "model_base": "1"}  # a loaded root: a model base
    sim.start()
    assert _int(sim, "inits") == 1
    assert _int(sim, f"joint_of_{base}") == w.resolve("Crate_joint").handle
    sim.step()

    # loaded while running: its child script's sysCall_init comes in the next pass, before its actuation
    second = H["LoadModel"](sim, [str(model), 0])
    assert w.get(second).name == "Crate#0"
    assert _int(sim, "custom_inits") == 2 and _int(sim, "inits") == 1
    calls = sim.signals.get_string("calls")
    sim.step()
    assert _int(sim, "inits") == 2
    assert sim.signals.get_string("calls")[len(calls):] == b"iaa"  # the new one's init, then both actuations
    assert _int(sim, f"joint_of_{second}") == w.resolve("Crate_joint#0").handle  # its own joint

    # a copy gets its original's scripts, finding its own objects
    (copy,) = H["CopyPasteObjects"](sim, [[base]])
    assert w.get(copy).name == "Crate#1"
    assert _int(sim, "custom_inits") == 3
    sim.step()
    assert _int(sim, "inits") == 3
    assert _int(sim, f"joint_of_{copy}") == w.resolve("Crate_joint#1").handle

    # a removed model's scripts end
    joint = w.resolve("Crate_joint#0").handle
    H["RemoveModel"](sim, [second])
    assert _int(sim, "cleanups") == 1 and _int(sim, "custom_cleanups") == 1
    assert second not in sim.scripts.scripts and joint not in sim.scripts.customization
    sim.step()
    sim.stop()  # the others' cleanups, and a restart begins them again
    assert sim.signals.get_int("inits") is None  # script signals go with the stop
    sim.start()
    assert _int(sim, "inits") == 2


def test_a_script_loads_a_model_of_the_scene_folder(trusted):
    """``sim.loadModel`` in a scene's script: a trusted file, its handle at once."""
    sim, model = trusted
    api = sim.scripts.scripts[sim.world.resolve("RG2").handle].sim_namespace()
    sim.start()
    base = api.loadModel(str(model))
    assert sim.world.get(base).name == "Crate" and _int(sim, "custom_inits") == 1
    sim.step()
    assert _int(sim, "inits") == 1


def _send(sim, model):
    for file in (model, model.parent / "crate.lua", model.parent / "crate_custom.lua"):
        H["TransferFile"](sim, [file.name, file.read_bytes()])
    return H["LoadModel"](sim, ["crate.xml", 1])


def test_a_clients_model_loads_without_its_scripts_unless_remote_code_is_allowed(tmp_path, caplog):
    model = _write_model(tmp_path / "models")
    sim = Simulation(SCENE, dt=0.05, realtime=False)
    try:
        with caplog.at_level(logging.WARNING, logger="simx.editing"):
            base = _send(sim, model)
        assert sim.world.get(base).name == "Crate"
        lines = [r.getMessage() for r in caplog.records if "do not run" in r.getMessage()]
        assert len(lines) == 1 and "2 script(s)" in lines[0] and "--allow-remote-code" in lines[0]
        sim.start()
        sim.step()
        assert _int(sim, "custom_inits") is None and _int(sim, "inits") is None
        assert base not in sim.scripts.scripts
    finally:
        sim.close()
    sim = Simulation(SCENE, dt=0.05, realtime=False, allow_remote_code=True)
    try:
        base = _send(sim, model)
        assert _int(sim, "custom_inits") == 1
        sim.start()
        assert _int(sim, "inits") == 1
        # it acts as its client: its files go to that client's folder, never the operator's
        script = sim.scripts.scripts[base]
        assert sim.editor.files.writer(script.path) == ""
    finally:
        sim.close()


def test_a_model_script_outside_its_folder_refuses_the_model(tmp_path):
    model = _write_model(tmp_path / "models")
    model.write_text(CRATE.replace("child_script=crate.lua", "child_script=../crate.lua"))
    (tmp_path / "crate.lua").write_text(CHILD)
    sim = Simulation(SCENE, dt=0.05, realtime=False, scene_paths=[model.parent])
    try:
        count = len(sim.world.objects)
        with pytest.raises(Exception, match="outside"):
            H["LoadModel"](sim, [str(model), 0])
        assert len(sim.world.objects) == count
    finally:
        sim.close()


def test_a_trusted_models_python_script_runs_only_with_the_operators_consent(tmp_path, caplog):
    """Its Python script is refused with one log line without ``--allow-python-scripts``; its
    Lua script runs, within the scene's scripts' budget."""
    model = _write_model(tmp_path / "models")
    model.write_text(CRATE.replace("child_script=crate.lua", "child_script=crate.py"))
    (model.parent / "crate.py").write_text("def sysCall_init():\n    sim.setInt32Signal('python_init', 1)\n")
    for allowed in (False, True):
        sim = Simulation(SCENE, dt=0.05, realtime=False, scene_paths=[model.parent], allow_python_scripts=allowed)
        try:
            with caplog.at_level(logging.ERROR, logger="simx.scripts"):
                base = H["LoadModel"](sim, [str(model), 0])
            script = sim.scripts.scripts[base]
            assert script.refused is not allowed and script.budget is sim.scripts.budget
            assert _int(sim, "custom_inits") == 1  # the Lua customization script runs either way
            sim.start()
            assert _int(sim, "python_init") == (1 if allowed else None)
        finally:
            sim.close()
    assert sum("--allow-python-scripts" in r.getMessage() for r in caplog.records) == 1
