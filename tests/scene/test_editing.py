"""Scene editing in-process: the editing handlers on a Simulation of the bundled UR5 scene.

Models, copies, removals, dummies and re-parenting while the simulation runs, the transfer
folder's path rules, scene loading and closing, and vision after an edit.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from conftest import SCENE
from simx_client.protocol import ArgumentError, ObjectTypeError, RemoteError, UnknownObjectError
from simx_server.commands.editing import EDITING_HANDLERS as H
from simx_server.sim.spec_tools import vrep_suffix
from simx_server.scene.simulation import Simulation
from simx_server.sim.state import RunState
from simx_server.sim.world import DUMMY, SHAPE

# Renderers at the first image (tests/conftest.py): only test_vision_renders_after_edit reads
# images, from a Simulation that makes them at load, as the server does by default.
pytestmark = pytest.mark.renderers_on_demand

BOX = Path(__file__).resolve().parents[1] / "scenes" / "model_box.xml"


@pytest.fixture
def sim():
    s = Simulation(SCENE, dt=0.05, realtime=False, scene_paths=[BOX.parent])  # server-side models
    yield s
    s.close()


def handles_by_name(world) -> dict[str, int]:
    return {o.name: o.handle for o in world.objects.values()}


def pose(world, h):
    return np.array(world.position(h, -1)), np.array(world.quaternion(h, -1))


def test_vrep_suffix_rule():
    assert vrep_suffix({"Box", "Box_geom"}, {"Table"}) == ""
    assert vrep_suffix({"Box", "Box_geom"}, {"Box", "Box_geom"}) == "#0"
    assert vrep_suffix({"Box", "Box_geom"}, {"Box", "Box_geom", "Box#0", "Box_geom#0"}) == "#1"
    assert vrep_suffix({"Box", "Box_geom"}, {"Box", "Box_geom#0"}) == "#1"  # one suffix for all


def test_load_transferred_model_while_running(sim):
    w = sim.world
    j1 = w.resolve("UR5_joint1").handle
    sim.start()
    w.set_joint_target_position(j1, 1.0)
    for _ in range(3):
        sim.step()
    before, q, t = handles_by_name(w), [w.joint_position(h) for h in w.motor_index], w.time
    targets, modes = w.target_position.copy(), w.mode.copy()
    err_before = abs(1.0 - w.joint_position(j1))

    H["TransferFile"](sim, ["box.xml", BOX.read_bytes()])
    base = H["LoadModel"](sim, ["box.xml", 1])

    assert w.get(base).name == "Box" and w.get(base).type == SHAPE
    assert base not in before.values()
    assert {n: h for n, h in handles_by_name(w).items() if n in before} == before
    assert [w.joint_position(h) for h in w.motor_index if h in before.values()] == q
    assert w.target_position[: len(targets)].tolist() == targets.tolist()
    assert w.mode[: len(modes)].tolist() == modes.tolist()
    assert w.time == t and sim.state is RunState.RUNNING
    assert w.get(w.resolve("Box_top").handle).settings == {"note": "top"}  # its custom text came along

    z0 = w.position(base, -1)[2]
    for _ in range(20):  # 1 s: falls on the bench (top at 0.75 m, box half size 0.05 m)
        sim.step()
    assert z0 == pytest.approx(1.2)
    assert w.position(base, -1)[2] == pytest.approx(0.80, abs=0.01)
    assert abs(1.0 - w.joint_position(j1)) < err_before / 10  # the arm went on toward its target


def test_second_load_gets_vrep_suffix_and_server_paths(sim):
    w = sim.world
    first = H["LoadModel"](sim, [str(BOX), 0])  # absolute server-side path
    second = H["LoadModel"](sim, [os.path.relpath(BOX, SCENE.parent), 0])  # relative to the scene
    assert (w.get(first).name, w.get(second).name) == ("Box", "Box#0")
    assert w.resolve("Box_top#0").settings == {"note": "top"}
    assert w.position(first, -1) == pytest.approx(w.position(second, -1))
    H["RemoveObject"](sim, [second])  # its material box_mat#0 stays in the scene
    third = H["LoadModel"](sim, [str(BOX), 0])
    assert w.get(third).name.startswith("Box#") and third != second
    with pytest.raises(RemoteError):
        H["LoadModel"](sim, ["no_such_model.xml", 0])
    with pytest.raises(RemoteError):
        H["LoadModel"](sim, ["never_transferred.xml", 1])


def test_transferred_files_may_be_erased_after_loading(sim):
    w = sim.world
    for name in ("model_tetra.xml", "tetra.obj"):
        H["TransferFile"](sim, [name, (BOX.parent / name).read_bytes()])
    tetra = H["LoadModel"](sim, ["model_tetra.xml", 1])
    for name in ("model_tetra.xml", "tetra.obj"):
        H["EraseFile"](sim, [name])
    (copy,) = H["CopyPasteObjects"](sim, [[tetra]])  # compiles the scene again: mesh from memory
    assert (w.get(tetra).name, w.get(copy).name) == ("Tetra", "Tetra#0")
    assert w.model.nmesh == 1 and w.model.mesh_vertnum[0] == 4


def test_model_assets_with_taken_names_are_renamed_alone(sim):
    w = sim.world
    xml = (b'<mujoco><asset><material name="ball_mat" rgba="0 0 1 1"/></asset><worldbody>'
           b'<body name="Blue" pos="0 1 2"><geom name="Blue_geom" type="sphere" size="0.05" material="ball_mat"/>'
           b'</body></worldbody></mujoco>')
    H["TransferFile"](sim, ["blue.xml", xml])
    assert w.get(H["LoadModel"](sim, ["blue.xml", 1])).name == "Blue"
    m = w.model
    assert m.mat_rgba[m.geom_matid[m.geom("Blue_geom").id]].tolist() == [0, 0, 1, 1]
    assert m.mat_rgba[m.geom_matid[m.geom("Sphere_geom").id]].tolist() == pytest.approx([0.9, 0.1, 0.1, 1])


def test_copy_paste_keeps_pose_joints_and_motors(sim):
    w = sim.world
    sphere, j2 = w.resolve("Sphere").handle, w.resolve("UR5_joint2").handle
    sim.start()
    w.set_joint_target_position(j2, 0.4)
    for _ in range(4):
        sim.step()
    before = handles_by_name(w)
    new_sphere, new_ur5 = H["CopyPasteObjects"](sim, [[sphere, w.resolve("UR5").handle]])

    assert (w.get(new_sphere).name, w.get(new_ur5).name) == ("Sphere#0", "UR5#0")
    assert {n: h for n, h in handles_by_name(w).items() if n in before} == before
    for a, b in ((sphere, new_sphere), (w.resolve("RG2").handle, w.resolve("RG2#0").handle)):
        for x, y in zip(pose(w, a), pose(w, b)):
            assert x == pytest.approx(y, abs=1e-9)
    j2c = w.resolve("UR5_joint2#0").handle
    assert w.joint_position(j2c) == w.joint_position(j2)
    assert w.target_position[w.motor_index[j2c]] == 0.4
    assert w.resolve("UR5_joint2#0").settings["mode"] == "position"
    rg2c = w.resolve("RG2#0").handle
    assert rg2c in sim.scripts.scripts and not sim.scripts.scripts[rg2c].running  # copied: its init in the next pass
    for _ in range(10):
        sim.step()
    assert w.joint_position(j2c) == pytest.approx(0.4, abs=0.01)
    copied = sim.scripts.scripts[rg2c]
    assert copied.running and copied.load_error is None and copied.start_error is None
    (third,) = H["CopyPasteObjects"](sim, [[sphere]])
    assert w.get(third).name == "Sphere#1"


def test_remove_object_and_model(sim):
    w = sim.world
    sphere = w.resolve("Sphere").handle
    (copy,) = H["CopyPasteObjects"](sim, [[sphere]])
    others = handles_by_name(w)
    del others["Sphere#0"]
    H["RemoveObject"](sim, [copy])
    with pytest.raises(UnknownObjectError):
        w.get(copy)
    assert handles_by_name(w) == others

    with pytest.raises(ArgumentError):
        H["RemoveObject"](sim, [-1])
    with pytest.raises(ObjectTypeError):
        H["RemoveModel"](sim, [w.resolve("UR5_joint1").handle])
    rg2 = w.resolve("RG2").handle
    assert rg2 in sim.scripts.scripts
    H["RemoveModel"](sim, [w.resolve("UR5").handle])
    assert not any(n.startswith(("UR5", "RG2", "kinect")) for n in handles_by_name(w))
    assert rg2 not in sim.scripts.scripts and w.model.nu == 0
    assert w.resolve("Sphere").handle == sphere


def test_remove_joint_welds_its_body_in_place(sim):
    w = sim.world
    j3 = w.resolve("UR5_joint3").handle
    w.set_joint_position(j3, 0.5)
    link3 = w.resolve("UR5_link3").handle
    p = pose(w, link3)
    motors = len(w.motor_index)  # 6 arm joints, the gripper, its passive (coupled) finger
    H["RemoveObject"](sim, [j3])
    assert j3 not in w.objects and len(w.motor_index) == motors - 1
    for x, y in zip(p, pose(w, link3)):
        assert x == pytest.approx(y, abs=1e-9)


def test_removed_handle_is_not_reused(sim):
    w = sim.world
    (copy,) = H["CopyPasteObjects"](sim, [[w.resolve("Sphere").handle]])
    H["RemoveObject"](sim, [copy])
    (again,) = H["CopyPasteObjects"](sim, [[w.resolve("Sphere").handle]])
    assert again != copy


def test_create_dummy(sim):
    w = sim.world
    d0 = H["CreateDummy"](sim, [0.1, None])
    d1 = H["CreateDummy"](sim, [0.02, [255, 0, 0] + [0] * 9])
    assert (w.get(d0).name, w.get(d1).name) == ("Dummy", "Dummy#0")
    assert w.get(d1).type == DUMMY and w.get(d1).parent == -1
    assert w.position(d1, -1) == [0.0, 0.0, 0.0]
    site = w.get(d1).mj_id
    assert w.model.site_size[site, 0] == pytest.approx(0.01)
    assert w.model.site_rgba[site].tolist() == [1.0, 0.0, 0.0, 1.0]
    with pytest.raises(ArgumentError):
        H["CreateDummy"](sim, [-1.0, None])
    with pytest.raises(ArgumentError):
        H["CreateDummy"](sim, [0.1, [1, 2, 3]])


def test_set_object_parent(sim):
    w = sim.world
    link6, table = w.resolve("UR5_link6").handle, w.resolve("Table").handle
    w.set_joint_position(w.resolve("UR5_joint2").handle, 0.7)
    kept = H["CreateDummy"](sim, [0.05, None])
    H["SetObjectParent"](sim, [kept, link6, True])
    assert w.get(kept).parent == link6
    assert w.position(kept, -1) == pytest.approx([0, 0, 0], abs=1e-9)  # world pose kept
    local = H["CreateDummy"](sim, [0.05, None])
    H["SetObjectParent"](sim, [local, link6, False])
    assert w.position(local, link6) == pytest.approx([0, 0, 0], abs=1e-9)  # local pose kept
    assert w.position(local, -1) != pytest.approx([0, 0, 0], abs=1e-3)

    rg2 = w.resolve("RG2").handle
    p = pose(w, rg2)
    H["SetObjectParent"](sim, [rg2, table, True])
    assert w.get(rg2).parent == table
    for x, y in zip(p, pose(w, rg2)):
        assert x == pytest.approx(y, abs=1e-9)
    assert w.resolve("RG2_openCloseJoint").handle in w.motor_index  # its joints and motor stay
    local_pose = w.relative_frame(rg2, table)
    H["SetObjectParent"](sim, [rg2, link6, False])
    for x, y in zip(local_pose, w.relative_frame(rg2, link6)):
        assert x == pytest.approx(y, abs=1e-9)

    sphere = w.resolve("Sphere").handle  # a dynamic shape: held by a weld (tests/sim/test_grasp_reparent.py)
    H["SetObjectParent"](sim, [sphere, table, True])
    assert w.get(sphere).parent == table and w.model.body_parentid[w.get(sphere).mj_id] == 0
    model = w.model
    with pytest.raises(ArgumentError):
        H["SetObjectParent"](sim, [w.resolve("UR5").handle, link6, True])  # its own descendant
    assert w.model is model  # failed edits change nothing


def test_transfer_folder_path_rules(sim):
    ed = sim.editor
    for bad in ("../x.xml", "/etc/passwd", "a/../../x.xml", str(ed.files_dir / "x.xml")):
        with pytest.raises(ArgumentError, match="outside the transfer folder"):
            H["TransferFile"](sim, [bad, b"data"])
    assert not (ed.files_dir.parent / "x.xml").exists()
    H["TransferFile"](sim, ["sub/x.xml", b"data"])
    assert (ed.files_dir / "sub" / "x.xml").read_bytes() == b"data"
    H["EraseFile"](sim, ["sub/x.xml"])
    with pytest.raises(RemoteError):
        H["EraseFile"](sim, ["sub/x.xml"])
    with pytest.raises(ArgumentError):
        H["EraseFile"](sim, ["../x.xml"])
    ed.close()
    assert not ed.files_dir.exists()


def test_load_scene_and_close_scene(sim):
    sim.start()
    with pytest.raises(RemoteError, match="stop the simulation first"):
        H["LoadScene"](sim, [SCENE.name, 0])
    sim.stop()
    old = sim.world
    H["CreateDummy"](sim, [0.1, None])
    H["LoadScene"](sim, [SCENE.name, 0])
    assert sim.world is not old and "Dummy" not in sim.world.by_name
    assert sorted(sim.world.objects) == list(range(1, len(sim.world.objects) + 1))
    assert sim.scripts.world is sim.world and sim.vision.world is sim.world
    dummy = H["CreateDummy"](sim, [0.1, None])  # the editor follows the new scene
    assert sim.world.get(dummy).name == "Dummy"

    sim.start()
    H["CloseScene"](sim, [])
    assert sim.state is RunState.STOPPED and sim.world.objects == {} and sim.world.model.nbody == 1


@pytest.fixture
def sim_at_load():
    s = Simulation(SCENE, dt=0.05, realtime=False, renderers_at_load=True)
    yield s
    s.close()


def test_vision_renders_after_edit(sim_at_load):
    sim = sim_at_load
    w = sim.world
    cam = w.resolve("kinect_rgb").handle
    H["CreateDummy"](sim, [0.01, None])  # an edit: renderers rebuilt for the new model
    res, before = sim.vision.image_bytes(cam, 0)
    p, r = w.frame(cam)
    centre = p + 0.4 * r[:, 2]  # V-REP sensors look along +z
    xml = (f'<mujoco><worldbody><body name="Wall" pos="{centre[0]} {centre[1]} {centre[2]}">'
           '<geom type="sphere" size="0.1" rgba="0 1 0 1" contype="0" conaffinity="0"/>'
           '</body></worldbody></mujoco>')
    H["TransferFile"](sim, ["wall.xml", xml.encode()])
    H["LoadModel"](sim, ["wall.xml", 1])
    res2, after = sim.vision.image_bytes(cam, 0)
    assert res2 == res == [640, 480]
    img0 = np.frombuffer(before, np.uint8).reshape(480, 640, 3)[240].astype(int)
    img1 = np.frombuffer(after, np.uint8).reshape(480, 640, 3)[240].astype(int)
    g0, g1 = img0[320], img1[320]
    assert not (g0[1] > g0[0] + 30 and g0[1] > g0[2] + 30)
    assert g1[1] > g1[0] + 30 and g1[1] > g1[2] + 30, f"centre pixel {g1} is not green"
    assert math.isfinite(float(np.frombuffer(sim.vision.depth_bytes(w.resolve("kinect_depth").handle)[1],
                                             np.float32)[0]))


def test_objects_placed_at_runtime_stay_through_edits_until_stop(sim):
    w = sim.world
    table, sphere = w.resolve("Table").handle, w.resolve("Sphere").handle
    sim.start()
    w.set_pose(table, -1, position=[0.2, 0.35, 0.0])  # simxSetObjectPosition on a static body
    H["CreateDummy"](sim, [0.1, None])
    assert w.position(table, -1) == pytest.approx([0.2, 0.35, 0.0])
    sim.stop()
    assert w.position(table, -1) == pytest.approx([0.1, 0.35, 0.0])  # initial pose as in the file
    assert w.position(sphere, -1) == pytest.approx([0.07, 0.76, 0.78])


def test_handler_argument_checks():
    s = Simulation(SCENE, dt=0.05, realtime=False)
    try:
        with pytest.raises(ArgumentError):
            H["CopyPasteObjects"](s, [5])
        with pytest.raises(ArgumentError):
            H["SetObjectParent"](s, [s.world.resolve("Sphere").handle, -1, "yes"])
        with pytest.raises(ArgumentError):
            H["TransferFile"](s, ["x.xml", "not bytes"])
        with pytest.raises(ArgumentError):
            H["LoadModel"](s, ["x.xml"])
    finally:
        s.close()
