"""What CoppeliaSim 4.x scenes' own scripts and old IK groups rely on (issue 50): an old IK
group's explicit-handling flag as the file stores it (``Var`` bit 6), the ``sim``/``simIK``
modules 4.5+ scripts ``require``, and the referenced handles (``Cr2``) a 4.6 IK script object
reads with ``sim.getReferencedHandle``."""

from __future__ import annotations

import struct

import numpy as np
import pytest

import tttwriter as W
from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read


def _arm(explicit: bool, extra: bytes = b"", cyclic: bool = False, enabled: bool = True) -> bytes:
    """Two hinge arm (the first unlimited with ``cyclic``), its tip linked to a target at the
    tip, one old IK group: damped least squares (0.05), 10 iterations (from its straight, singular
    start the pseudo-inverse of ``_CIkGroup_old``'s defaults jumps about, as it would on V-REP)."""
    return (W.cuboid_shape(1, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.joint(2, 1, "J1", (0, 0, 0.15), quat=(0.7071068, 0.7071068, 0, 0), limits=(-3.0, 6.0), cyclic=cyclic)
            + W.cuboid_shape(3, 2, "L1", (0.05, 0.3, 0.05), (0, 0.15, 0), mass=0.2)
            + W.joint(4, 3, "J2", (0, 0.15, 0), limits=(-3.0, 6.0))
            + W.cuboid_shape(5, 4, "L2", (0.05, 0.3, 0.05), (0, 0.15, 0), mass=0.2)
            + W.dummy(6, 5, "Tip", (0, 0.15, 0), linked=7, link_type=5)
            + W.dummy(7, -1, "Target", (0, 0, 0.85), linked=6, link_type=5)
            + extra + W.ik_group("Arm", [(6, 1, 7)], explicit=explicit, enabled=enabled,
                                         solver=(10, 0.05, 1)))


def _load(tmp_path, body: bytes, program: int = 40100) -> Simulation:
    f = tmp_path / "scene.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=program))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "scene")
    return Simulation(xml, realtime=False)


def test_explicit_group_is_read_from_the_var_flags(tmp_path):
    """coppeliaSimLib ``CIkGroup_old::serialize``: ``Var`` bit 6 is explicit handling, bit 0 enabled."""
    for explicit in (True, False):
        for enabled in (True, False):
            f = tmp_path / f"g{explicit}{enabled}.ttt"
            f.write_bytes(W.ttt_file(_arm(explicit, enabled=enabled)))
            group = reader.read(f).ik_groups[0]
            assert (group.explicit, group.enabled) == (explicit, enabled)


def test_explicit_group_runs_only_when_called(tmp_path):
    """An explicit group leaves the joints' targets alone until ``sim.handleIkGroup``."""
    sim = _load(tmp_path, _arm(explicit=True))
    try:
        api = client_context(sim).sim
        j1, tip, target = api.getObject("/J1"), api.getObject("/Tip"), api.getObject("/Target")
        sim.start()
        api.setObjectPosition(target, -1, [0.1, 0.0, 0.78])
        api.setJointTargetPosition(j1, 0.3)
        for _ in range(3):
            sim.step()
        assert api.getJointTargetPosition(j1) == pytest.approx(0.3)
        for _ in range(5):
            api.handleIkGroup(api.getIkGroupHandle("Arm"))
        assert api.handleIkGroup(api.getIkGroupHandle("Arm")) == 1  # sim.ikresult_success
        for _ in range(20):
            sim.step()
        gap = np.linalg.norm(np.subtract(api.getObjectPosition(tip, -1), api.getObjectPosition(target, -1)))
        assert gap < 0.01
    finally:
        sim.close()


def test_automatic_group_follows_a_moved_target(tmp_path):
    """A group that is not explicit is solved at every step: a target a client moves is followed."""
    sim = _load(tmp_path, _arm(explicit=False))
    try:
        api = client_context(sim).sim
        tip, target = api.getObject("/Tip"), api.getObject("/Target")
        sim.start()
        api.setObjectPosition(target, -1, [0.1, 0.0, 0.78])
        for _ in range(60):
            sim.step()
        gap = np.linalg.norm(np.subtract(api.getObjectPosition(tip, -1), api.getObjectPosition(target, -1)))
        assert gap < 0.01
    finally:
        sim.close()


def _gap(api) -> float:
    return float(np.linalg.norm(np.subtract(api.getObjectPosition(api.getObject("/Tip"), -1),
                                            api.getObjectPosition(api.getObject("/Target"), -1))))


def test_handle_ik_group_as_coppeliasim_handles_it(tmp_path):
    """coppeliaSimLib ``simHandleIkGroup_internal``: one group only if tagged explicit (else an
    error), ``sim.handle_all`` every group, ``sim.handle_all_except_explicit`` the others; a
    group saved inactive is never solved (``CIkGroup_old::computeGroupIk``: not performed)."""
    for explicit, enabled in ((False, True), (True, True), (True, False), (False, False)):
        folder = tmp_path / f"{explicit}{enabled}"
        folder.mkdir()
        sim = _load(folder, _arm(explicit=explicit, enabled=enabled))
        try:
            api = client_context(sim).sim
            arm = api.getIkGroupHandle("Arm")
            sim.start()
            api.setObjectPosition(api.getObject("/Target"), -1, [0.1, 0.0, 0.78])
            start = _gap(api)
            for _ in range(40):
                sim.step()
            solved_by_steps = _gap(api) < 0.01
            assert solved_by_steps is (enabled and not explicit), (explicit, enabled)
            if not explicit:
                with pytest.raises(Exception, match="not tagged for explicit handling"):
                    api.handleIkGroup(arm)
            else:
                assert api.handleIkGroup(arm) == (1 if enabled else 0)  # success / not performed
            assert api.handleIkGroup(api.handle_all_except_explicit) == int(enabled and not explicit)
            for _ in range(10):
                assert api.handleIkGroup(api.handle_all) == int(enabled)  # explicit ones too
            for _ in range(20):
                sim.step()
            assert (_gap(api) < 0.01) is enabled and (enabled or _gap(api) == pytest.approx(start, abs=0.05))
        finally:
            sim.close()


IK_SCRIPT = """
sim = require('sim')
simIK = require 'simIK'
local sim2 = require('sim-2')
function sysCall_init()
    self = sim.getObject('.')
    sim.setInt32Signal('self', self)
    sim.setInt32Signal('tip', sim.getReferencedHandle(self, 'ik.tip'))
    sim.setInt32Signal('same', (sim2 == sim and type(simIK.createEnvironment) == 'function') and 1 or 0)
end
"""


def _refs(tag: str, *handles: int) -> bytes:
    """A tagged referenced-handles record (``Cr2``: tag, count, handles)."""
    return W.rec("Cr2", W.string(tag) + W.i32(len(handles), *handles))


def test_46_script_requires_sim_and_reads_its_references(tmp_path):
    """4.5+ scripts' ``require('sim')``/``'simIK'`` return the ``sim`` and ``simIK`` tables (CoppeliaSim's
    ``lua/sim.lua``, the simIK plugin's ``simIK.lua``); ``sim.getReferencedHandle`` answers what the
    file stored (coppeliaSimLib ``CSceneObject::serialize``: ``Cr2``)."""
    body = _arm(False, W.script_object(8, 1, "IK", IK_SCRIPT, kind=1, extra=_refs("ik.tip", 6)))
    sim = _load(tmp_path, body, program=40600)
    try:
        w = sim.world
        sim.start()
        sim.step()
        assert sim.signals.get_int("self") == w.resolve("IK").handle
        assert sim.signals.get_int("tip") == w.resolve("Tip").handle
        assert sim.signals.get_int("same") == 1
    finally:
        sim.close()


def test_untagged_references_are_read(tmp_path):
    """``Crh``: count, then (object type, handle, 0) per entry; tag ``""``."""
    crh = W.rec("Crh", W.i32(2) + W.i32(0, 6, 0) + W.i32(0, 7, 0))
    f = tmp_path / "r.ttt"
    f.write_bytes(W.ttt_file(W.dummy(6, -1, "A") + W.dummy(7, -1, "B", extra=crh)))
    assert reader.read(f).objects[7].references == {"": [6, 7]}
    bad = W.rec("Cr2", W.string("t") + struct.pack("<i", 5))
    f.write_bytes(W.ttt_file(W.dummy(7, -1, "B", extra=bad)))
    with pytest.raises(Exception, match="truncated"):
        reader.read(f)


def test_simik_solves_chains_with_an_unlimited_joint(tmp_path):
    """simIK with a cyclic (unlimited) joint in the chain: its bounds stay infinite (no NaN from
    the middle of an infinite interval), the group is solved and the scene follows."""
    sim = _load(tmp_path, _arm(explicit=True, cyclic=True))
    try:
        api, ik = client_context(sim).sim, client_context(sim).simik
        base, tip, target = api.getObject("/Base"), api.getObject("/Tip"), api.getObject("/Target")
        sim.start()
        api.setObjectPosition(target, -1, [0.1, 0.0, 0.78])
        env = ik.createEnvironment()
        group = ik.createGroup(env)
        ik.addElementFromScene(env, group, base, tip, target, ik.constraint_position)
        for _ in range(30):  # as a 4.x IK script does at each actuation
            ik.handleGroup(env, group, {"syncWorlds": True, "allowError": True})
            sim.step()
        gap = np.linalg.norm(np.subtract(api.getObjectPosition(tip, -1), api.getObjectPosition(target, -1)))
        assert gap < 0.01
    finally:
        sim.close()


def _gripper() -> bytes:
    """A model ``Robot`` (alias) holding a gripper model with two ``finger`` links and its
    ``openCloseJoint``; a second, unrelated ``openCloseJoint`` at the top level."""
    return (W.cuboid_shape(1, -1, "Robot_base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False,
                           extra=W.alias("Robot") + W.model_base())
            + W.cuboid_shape(2, 1, "RG2", (0.1, 0.1, 0.1), (0, 0, 0.2), dynamic=False, extra=W.model_base())
            + W.joint(3, 2, "RG2_openCloseJoint", (0, 0, 0.1), kind=11, common_extra=W.alias("openCloseJoint"))
            + W.dummy(4, 3, "RG2_finger", (0.02, 0, 0), extra=W.alias("finger"))
            + W.dummy(5, 3, "RG2_finger0", (-0.02, 0, 0), extra=W.alias("finger"))
            + W.dummy(6, -1, "other_openCloseJoint", (1, 0, 0), extra=W.alias("openCloseJoint")))


def test_object_alias_options_follow_coppeliasim(tmp_path):
    """``sim.getObjectAlias`` as coppeliaSimLib ``simGetObjectAlias_internal``: -1 the alias, 0 with
    its order among same-alias siblings, 1 the short path (model bases kept, an ancestor left
    out where the path still names the object), 2 the full path, 3/4 ``alias__HANDLE__``."""
    sim = _load(tmp_path, _gripper())
    try:
        api, w = client_context(sim).sim, sim.world
        joint, f0, f1 = (w.resolve(n).handle for n in ("RG2_openCloseJoint", "RG2_finger", "RG2_finger0"))
        assert api.getObjectAlias(joint) == "openCloseJoint"
        assert api.getObjectAlias(joint, 1) == "/Robot/RG2/openCloseJoint"
        assert api.getObjectAlias(joint, 2) == "/Robot/RG2/openCloseJoint"
        assert (api.getObjectAlias(f0, 0), api.getObjectAlias(f1, 0)) == ("finger[0]", "finger[1]")
        assert api.getObjectAlias(f1, 1) == "/Robot/RG2/finger[1]"  # the joint left out
        assert api.getObjectAlias(f1, 2) == "/Robot/RG2/openCloseJoint/finger[1]"
        assert api.getObject(api.getObjectAlias(f1, 1)) == f1
        assert api.getObjectAlias(joint, 3) == f"openCloseJoint__{joint}__"  # two in the scene
        assert api.getObjectAlias(f0, 4) == f"finger__{f0}__"
        assert api.getObjectAlias(joint, 6) == "/openCloseJoint{0}"  # two in the scene, this one first
        assert api.getObjectAlias(f1, 6) == "/finger{1}" and api.getObjectAlias(f1, 7) == "/RG2/finger{1}"
        assert api.getObjectAlias(f1, 9) == "/Robot/RG2/finger{1}"
        assert api.getObject(api.getObjectAlias(f1, 8)) == f1
        with pytest.raises(Exception, match="options"):
            api.getObjectAlias(joint, 10)
        rg2 = w.resolve("RG2").handle
        assert api.getObject("./openCloseJoint", {"proxy": rg2}) == joint  # simGetObject_internal
        assert api.getObject("..", {"proxy": joint}) == rg2
        assert api.getObject("/openCloseJoint", {"proxy": rg2}) == joint  # absolute: the first in tree order
        assert api.getObject("./finger", {"proxy": w.resolve("other_openCloseJoint").handle, "noError": True}) == -1
        with pytest.raises(Exception, match="999"):
            api.getObject("./finger", {"proxy": 999})
        # the deprecated sim.getObjectHandle takes the same paths (4.2+; a client: '.' is the scene root)
        assert api.getObjectHandle("./openCloseJoint") == joint == api.getObjectHandle("./Robot/RG2/openCloseJoint")
    finally:
        sim.close()


COUNTER = """
function sysCall_actuation()
    sim.setInt32Signal('passes', (sim.getInt32Signal('passes') or 0) + 1)
end
function handleIk()
    sim.setInt32Signal('called', (sim.getInt32Signal('called') or 0) + 1)
end
"""


def test_scripts_are_disabled_and_called_by_handle(tmp_path):
    """``sim.setScriptInt32Param(h, sim.scriptintparam_enabled, 0)`` stops a script's system
    callbacks (coppeliaSimLib ``simSetScriptInt32Param_internal``: ``setScriptIsDisabled``); a 4.6
    customization script object answers ``sim.callScriptFunction`` by its handle."""
    body = (W.cuboid_shape(1, -1, "Robot", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.script_object(2, 1, "IK", COUNTER, kind=6))
    sim = _load(tmp_path, body, program=40600)
    try:
        api = client_context(sim).sim
        ik = api.getObject("/Robot/IK")
        sim.start()
        for _ in range(3):
            sim.step()
        passes = sim.signals.get_int("passes")
        assert passes >= 3 and api.getScriptInt32Param(ik, api.scriptintparam_enabled) == 1
        assert api.setScriptInt32Param(ik, api.scriptintparam_enabled, 0) == 1
        for _ in range(3):
            sim.step()
        assert sim.signals.get_int("passes") == passes
        assert api.getScriptInt32Param(ik, api.scriptintparam_enabled) == 0
        assert api.getScriptInt32Param(ik, api.scriptintparam_type) == api.scripttype_customization
        api.callScriptFunction("handleIk", ik)
        assert sim.signals.get_int("called") == 1
        api.setScriptInt32Param(ik, api.scriptintparam_enabled, 1)
        sim.step()
        assert sim.signals.get_int("passes") == passes + 1
        with pytest.raises(Exception, match="no script"):
            api.setScriptInt32Param(api.getObject("/Robot"), api.scriptintparam_enabled, 0)
    finally:
        sim.close()


def test_old_scripts_colours_and_proximity_of_dummies(tmp_path):
    """``sim.setShapeColor`` with 0-255 components is clamped (CoppeliaSim keeps them, OpenGL
    clamps them when drawing); ``'@backCompatibility1:H'`` is shape H with the 3.1.3 colour
    correction (coppeliaSimLib ``_simSetShapeColor``); ``sim.checkProximitySensor`` of a dummy
    sees its origin inside the volume (``CProxSensorRoutine::_detectDummy``), a ray never."""
    body = (W.cuboid_shape(1, -1, "Box", (0.1, 0.1, 0.1), (2, 0, 0.05), dynamic=False)
            + W.proximity_sensor(2, -1, "Pyramid", kind=30, offset=0.05, reach=0.5, sizes=(0.2, 0.2, 0.4, 0.4, 0, 0))
            + W.proximity_sensor(3, -1, "Ray", kind=34, reach=0.5, pos=(0.3, 0, 0))
            + W.dummy(4, -1, "Inside", (0.05, 0, 0.3)) + W.dummy(5, -1, "Beside", (0.3, 0, 0.3)))
    sim = _load(tmp_path, body)
    try:
        api, w = client_context(sim).sim, sim.world
        box = api.getObject("/Box")
        assert api.setShapeColor(box, None, 0, [255, 0, 128]) == 1
        geom = next(g for g in range(w.model.ngeom) if w.model.geom_bodyid[g] == w.get(box).mj_id)
        assert list(w.model.geom_rgba[geom][:3]) == pytest.approx([1.0, 0.0, 1.0])
        assert api.setShapeColor(f"@backCompatibility1:{box}", None, 0, [0.6, 0.35, 0.1]) == 1
        assert list(w.model.geom_rgba[geom][:3]) == pytest.approx([1.0, 0.6 / 0.85, 0.35 / 0.85], abs=1e-6)
        with pytest.raises(Exception, match="no handle"):
            api.setShapeColor("@backCompatibility1:x", None, 0, [0, 0, 0])
        pyramid, ray = api.getObject("/Pyramid"), api.getObject("/Ray")
        inside, beside = api.getObject("/Inside"), api.getObject("/Beside")
        result, dist, point = api.checkProximitySensor(pyramid, inside)
        assert result == 1 and point == pytest.approx([0.05, 0, 0.3], abs=1e-6) and dist == pytest.approx(0.30414, abs=1e-4)
        assert api.checkProximitySensor(pyramid, beside)[0] == 0  # 0.3 m aside, the volume is 0.15 m wide there
        assert api.checkProximitySensor(ray, beside)[0] == 0  # straight above the ray: rays never see dummies
    finally:
        sim.close()


BUNDLED = """
local path = require('models.path_customization-2')
function sysCall_init()
    path.init()
    sim.setInt32Signal('loaded', path.anything() == nil and 1 or 0)
end
"""


def test_bundled_model_modules_load_headless(tmp_path, caplog):
    """A 4.x path's customization script requires CoppeliaSim's bundled
    ``models.path_customization-2``: it loads, its (GUI) functions do nothing, one log line says so."""
    body = (W.dummy(1, -1, "Path") + W.script_object(2, 1, "Script", BUNDLED, kind=1))
    sim = _load(tmp_path, body, program=40600)
    try:
        with caplog.at_level("INFO"):
            sim.start()
            sim.step()
        assert sim.signals.get_int("loaded") == 1
        said = [r.getMessage() for r in caplog.records if "models.path_customization-2" in r.getMessage()]
        assert len(said) == 1 and "do nothing" in said[0]
    finally:
        sim.close()


def test_selection_and_texture_calls_of_old_scripts(tmp_path, caplog):
    """``sim.addObjectToSelection`` / ``removeObjectFromSelection`` / ``isObjectInSelection``
    (coppeliaSimLib ``simAddObjectToSelection_internal``...): single, tree, chain, all; a
    shape's texture parameters (``sim.shapefloatparam_texture_x``...) on a shape whose texture
    simx cannot move are accepted and said, once, to leave it where it is."""
    sim = _load(tmp_path, _gripper())
    try:
        api, w = client_context(sim).sim, sim.world
        rg2, joint = w.resolve("RG2").handle, w.resolve("RG2_openCloseJoint").handle
        base = w.resolve("Robot_base").handle
        assert api.addObjectToSelection(api.handle_single, joint) == 1
        assert api.getObjectSelection() == [joint] and api.isObjectInSelection(joint) == 1
        api.addObjectToSelection(api.handle_chain, joint)
        assert sorted(api.getObjectSelection()) == sorted([joint, rg2, base])
        api.removeObjectFromSelection(api.handle_tree, rg2)
        assert api.getObjectSelection() == [base] and api.isObjectInSelection(joint) == 0
        api.removeObjectFromSelection(api.handle_all, -1)
        assert api.getObjectSelection() == []
        with pytest.raises(Exception, match="what must be"):
            api.addObjectToSelection(5, joint)
        from simx_server.sim import texture_motion
        texture_motion._told.discard("Robot_base")  # said once per shape and server
        with caplog.at_level("INFO"):
            for v in (0.1, 0.2):
                assert api.setObjectFloatParameter(base, api.shapefloatparam_texture_x, v) == 1
        assert len([r for r in caplog.records if "stay where they are" in r.getMessage()]) == 1
        with pytest.raises(Exception):
            api.setObjectFloatParameter(joint, api.shapefloatparam_texture_x, 0.1)  # not a shape
    finally:
        sim.close()


PLUGINS = """
simUI = require('simUI')
simVision = require('simVision')
function sysCall_init()
    sim.setInt32Signal('ui', simUI.create('<ui/>'))
    local ok, err = pcall(require, 'simOpenMesh')
    sim.setStringSignal('mesh', tostring(ok) .. ' ' .. tostring(err))
    ok, err = pcall(simVision.sensorImgToWorkImg, 1)
    sim.setStringSignal('vision', tostring(ok) .. ' ' .. tostring(err))
end
function sysCall_vision(inData)
    simVision.sensorImgToWorkImg(inData.handle)
end
"""


def test_plugin_modules_as_a_headless_coppeliasim_has_them(tmp_path):
    """``require('simUI')`` is the headless simUI table (its calls logged no-ops, ``create`` -1);
    a plugin simx lacks (``simOpenMesh``) fails to load, saying so; ``simVision`` loads (a 4.5+
    vision sensor's script requires it at its top) and its functions work on vision sensors only
    (tests/scripts/test_vision_callbacks.py has the rest): the script's other callbacks run."""
    sim = _load(tmp_path, W.dummy(1, -1, "Holder") + W.script_object(2, 1, "Script", PLUGINS, kind=1), program=40600)
    try:
        sim.start()
        sim.step()
        assert sim.signals.get_int("ui") == -1
        assert sim.signals.get_string("mesh").startswith(b"false simOpenMesh is a CoppeliaSim plugin")
        assert sim.signals.get_string("vision").startswith(b"false")
        assert b"simVision.sensorImgToWorkImg: object 'Holder' (handle 1) is a dummy, not a vision sensor" in \
            sim.signals.get_string("vision")
    finally:
        sim.close()


def test_a_script_saved_disabled_exists_and_starts_when_enabled(tmp_path):
    """A script saved disabled is kept, not run; ``sim.setScriptInt32Param(h,
    sim.scriptintparam_enabled, 1)`` starts it (top level, ``sysCall_init``) at once."""
    text = "function sysCall_init() sim.setInt32Signal('init', 1) end\n" + COUNTER
    body = (W.cuboid_shape(1, -1, "Robot", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.script_object(2, 1, "Script", text, kind=1, disabled=True))
    f = tmp_path / "scene.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=40600))
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "scene")
    assert not any("disabled" in line for line in report.lines())
    sim = Simulation(xml, realtime=False)
    try:
        api = client_context(sim).sim
        script = api.getObject("/Robot/Script")
        sim.start()
        for _ in range(3):
            sim.step()
        assert sim.signals.get_int("init") is None and sim.signals.get_int("passes") is None
        assert api.getScriptInt32Param(script, api.scriptintparam_enabled) == 0
        api.setScriptInt32Param(script, api.scriptintparam_enabled, 1)
        assert sim.signals.get_int("init") == 1
        sim.step()
        assert sim.signals.get_int("passes") == 1
    finally:
        sim.close()


def test_configuration_trees_put_a_robot_back(tmp_path):
    """``sim.getConfigurationTree`` / ``setConfigurationTree`` (coppeliaSimLib ``CMemorizedConf_old``):
    joints return to their positions and a moved object to its pose; a foreign buffer is refused."""
    sim = _load(tmp_path, _arm(explicit=True) + W.cuboid_shape(9, -1, "Crate", (0.1, 0.1, 0.1), (1, 0, 0.05),
                                                               dynamic=False))
    try:
        api = client_context(sim).sim
        j1, j2, crate = api.getObject("/J1"), api.getObject("/J2"), api.getObject("/Crate")
        api.setJointPosition(j1, 0.4)
        saved, scene = api.getConfigurationTree(api.getObject("/Base")), api.getConfigurationTree(api.handle_all)
        api.setJointPosition(j1, -0.7)
        api.setJointPosition(j2, 0.9)
        api.setObjectPosition(crate, -1, [1.5, 0.5, 0.05])
        assert api.setConfigurationTree(saved) == 1
        assert (api.getJointPosition(j1), api.getJointPosition(j2)) == pytest.approx((0.4, 0.0))
        assert api.getObjectPosition(crate, -1) == pytest.approx([1.5, 0.5, 0.05])  # not in the arm's tree
        api.setConfigurationTree(scene)
        assert api.getObjectPosition(crate, -1) == pytest.approx([1.0, 0.0, 0.05])
        with pytest.raises(Exception, match="not a buffer"):
            api.setConfigurationTree(b"elsewhere")
    finally:
        sim.close()


def test_extension_strings_are_read(tmp_path):
    """``sim.getExtensionString`` answers the object's ``Rst`` text (coppeliaSimLib
    ``CSceneObject::serialize``), or a key's value in it (``tt::getValueOfKey``, ``a@b`` nested)."""
    text = "povray {pattern {3} finish {phong {0.5}}} other {x}"
    body = W.dummy(1, -1, "Marked", extra=W.rec("Rst", W.string(text))) + W.dummy(2, -1, "Plain")
    sim = _load(tmp_path, body)
    try:
        api = client_context(sim).sim
        marked, plain = api.getObject("/Marked"), api.getObject("/Plain")
        assert api.getExtensionString(marked, -1) == text
        assert api.getExtensionString(marked, -1, "povray") == "pattern {3} finish {phong {0.5}}"
        assert api.getExtensionString(marked, -1, "phong@finish@povray") == "0.5"
        assert api.getExtensionString(marked, -1, "missing") is None
        assert api.getExtensionString(plain, -1) is None
        with pytest.raises(Exception, match="scene's"):
            api.getExtensionString(-1, -1)
    finally:
        sim.close()


def test_ik_group_is_solved_with_its_own_settings(tmp_path):
    """An old group's iterations (``Mit``), damping (``_pg``), method (``Cmt``) and element
    precision (``_r2``) are the file's (coppeliaKinematicsRoutines ``CIkGroupContainer::computeIk``
    stops after that many steps; within precision it succeeds): a target 1.3 cm away is not reached
    within 0.5 mm by 3 damped steps (λ 0.1) and is by 6, or by 3 with λ 0.01; a 2 cm precision
    accepts 3 damped steps."""
    def arm(solver, precision=None):
        return (W.cuboid_shape(1, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
                + W.joint(2, 1, "J1", (0, 0, 0.15), quat=(0.7071068, 0.7071068, 0, 0), limits=(-3.0, 6.0))
                + W.cuboid_shape(3, 2, "L1", (0.05, 0.3, 0.05), (0, 0.15, 0), mass=0.2)
                + W.joint(4, 3, "J2", (0, 0.15, 0), limits=(-3.0, 6.0), position=0.6)
                + W.cuboid_shape(5, 4, "L2", (0.05, 0.3, 0.05), (0, 0.15, 0), mass=0.2)
                + W.dummy(6, 5, "Tip", (0, 0.15, 0), linked=7, link_type=5)
                + W.dummy(7, -1, "Target", (0, 0, 0.85), linked=6, link_type=5)
                + W.ik_group("Arm", [(6, 1, 7)], explicit=True, solver=solver, precision=precision))

    outcomes = []
    for n, (solver, precision) in enumerate((((3, 0.1, 1), None), ((6, 0.1, 1), None), ((3, 0.01, 1), None),
                                             ((3, 0.1, 1), (0.02, 0.1)))):
        folder = tmp_path / str(n)
        folder.mkdir()
        sim = _load(folder, arm(solver, precision))
        try:
            api = client_context(sim).sim
            sim.start()
            tip = api.getObjectPosition(api.getObject("/Tip"), -1)
            api.setObjectPosition(api.getObject("/Target"), -1, [tip[0] + 0.01, tip[1], tip[2] - 0.008])
            outcomes.append(api.handleIkGroup(api.getIkGroupHandle("Arm")))
        finally:
            sim.close()
    assert outcomes == [2, 1, 1, 1]  # sim.ikresult_fail, then success


def test_generate_ik_path_is_the_groups_own_straight_line(tmp_path):
    """``sim.generateIkPath`` (coppeliaSimLib ``simGenerateIkPath_internal``): ``ptCnt``
    configurations from the joints' positions to ones that put the tip on the target, solved
    with the group's settings, the scene left as it was; a held joint that makes the target
    unreachable, or a configuration that collides with a pair given, fails the path (nil)."""
    wall = W.cuboid_shape(8, -1, "Wall", (0.04, 0.04, 0.04), (0.1, 0.0, 0.78), dynamic=False)
    sim = _load(tmp_path, _arm(explicit=True, extra=wall))
    try:
        api = client_context(sim).sim
        arm, j1, j2 = api.getIkGroupHandle("Arm"), api.getObject("/J1"), api.getObject("/J2")
        tip, target = api.getObject("/Tip"), api.getObject("/Target")
        sim.start()
        api.setJointPosition(j2, 0.6)  # away from the straight, singular start
        api.setObjectPosition(target, -1, [0.1, 0.0, 0.78])
        before = [api.getJointPosition(j) for j in (j1, j2)]
        path = api.generateIkPath(arm, [j1, j2], 5)
        assert len(path) == 10 and path[:2] == pytest.approx(before)
        assert [api.getJointPosition(j) for j in (j1, j2)] == before
        assert api.getObjectPosition(target, -1) == pytest.approx([0.1, 0.0, 0.78])
        for j, q in zip((j1, j2), path[-2:]):
            api.setJointPosition(j, q)
        assert api.getObjectPosition(tip, -1) == pytest.approx([0.1, 0.0, 0.78], abs=2e-3)
        for j, q in zip((j1, j2), before):
            api.setJointPosition(j, q)
        assert api.generateIkPath(arm, [j1, j2], 5, None, [1, 0]) is None  # J2 alone cannot get there
        assert api.generateIkPath(arm, [j1, j2], 5, [api.getObject("/L2"), api.getObject("/Wall")]) is None
        assert len(api.generateIkPath(arm, [j1, j2], 5, [-1, api.getObject("/Wall")])) == 10  # pair skipped
        with pytest.raises(Exception, match="ptCnt"):
            api.generateIkPath(arm, [j1, j2], 1)
    finally:
        sim.close()


def test_check_ik_group_and_its_properties(tmp_path):
    """``sim.checkIkGroup`` solves from the joints' positions and moves nothing;
    ``sim.setIkGroupProperties`` / ``setIkElementProperties`` change what the next solve uses."""
    sim = _load(tmp_path, _arm(explicit=True))  # damped least squares (0.05), 10 iterations
    try:
        api = client_context(sim).sim
        arm, j1, j2 = api.getIkGroupHandle("Arm"), api.getObject("/J1"), api.getObject("/J2")
        sim.start()
        api.setObjectPosition(api.getObject("/Target"), -1, [0.1, 0.0, 0.78])
        before = [api.getJointPosition(j) for j in (j1, j2)], [api.getJointTargetPosition(j) for j in (j1, j2)]
        result, values = api.checkIkGroup(arm, [j1, j2])
        assert result == 1 and len(values) == 2
        assert ([api.getJointPosition(j) for j in (j1, j2)], [api.getJointTargetPosition(j) for j in (j1, j2)]) == before
        held, only_j2 = api.checkIkGroup(arm, [j1, j2], [1, 0])  # J1 held: J2 alone cannot reach it
        assert held == 2 and only_j2[0] == before[0][0]
        api.setIkGroupProperties(arm, 1, 1, 0.05)  # one step is not enough
        assert api.checkIkGroup(arm, [j1, j2])[0] == 2
        api.setIkElementProperties(arm, api.getObject("/Tip"), 7, [0.2, 0.1])  # but 0.2 m is near enough
        assert api.checkIkGroup(arm, [j1, j2])[0] == 1
        with pytest.raises(Exception, match="resolutionMethod"):
            api.setIkGroupProperties(arm, 7, 1, 0.05)
    finally:
        sim.close()
