"""The converter on a synthetic scene: the MJCF simx loads, its ``simx:`` settings (joint modes,
the scripts contract: child/customization script files, threaded, vrep_version, parameters),
poses from the file, and simx-convert's report."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.ttt import convert, reader
from simx_server.scene.ttt.cli import main as simx_convert

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


@pytest.fixture()
def converted(tmp_path):
    f = tmp_path / "cell.ttt"
    f.write_bytes(W.simple_scene())
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "cell")
    return tmp_path / "out", xml, report


def _settings(xml):
    spec = mujoco.MjSpec.from_file(str(xml))
    return {t.name: t.data for t in spec.texts}


def test_settings_and_scripts(converted):
    out, xml, _ = converted
    texts = _settings(xml)
    assert texts["simx:Base_joint1"] == "mode=position max_velocity=2"
    assert texts["simx:Link#0"] == "child_script=Link_0_child.lua vrep_version=40100"
    base = dict(item.split("=") for item in texts["simx:Base"].split())
    assert base == {"child_script": "Base_child.lua", "threaded": "1",
                    "script_parameters": "Base_child_parameters.json", "vrep_version": "40100"}
    assert (out / "Base_child.lua").read_text() == "simRemoteApi.start(19999)\n"
    assert json.loads((out / "Base_child_parameters.json").read_text()) == [
        {"name": "port", "value": "19999", "unit": "int"}]
    assert texts["simx:Cube"] == "customization_script=Cube_customization.lua vrep_version=40100"
    assert "sysCall_init" in (out / "Link_0_child.lua").read_text()
    # collections: V-REP's elements in order, additive (+) and subtractive (-)
    assert texts["simx:collection:Arm"] == "items=+tree:Base,-single:Tip"
    assert texts["simx:collection:NotCube"] == "items=+all,-single:Cube"


def test_model_poses_and_dynamics(converted):
    _, xml, _ = converted
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    j = m.joint("Base_joint1")
    assert m.qpos0[j.qposadr[0]] == pytest.approx(0.3)  # the file's position, as ref
    assert d.body("Link#0").xpos == pytest.approx([0, 0, 0.45])
    c, s = np.cos(0.3), np.sin(0.3)
    np.testing.assert_allclose(d.body("Link#0").xmat.reshape(3, 3)[:2, :2], [[c, -s], [s, c]], atol=1e-6)  # Prt is f32
    assert d.site("Tip").xpos == pytest.approx([0, 0, 0.65])
    assert m.body("Link#0").mass[0] == pytest.approx(0.5)
    assert m.body("Cube").jntnum[0] == 1 and m.jnt_type[m.body("Cube").jntadr[0]] == mujoco.mjtJoint.mjJNT_FREE
    assert m.body("Floor").jntnum[0] == 0 and m.body("Base").jntnum[0] == 0  # static: welded
    assert m.actuator("Base_joint1_motor").forcerange == pytest.approx([-10, 10])
    for _ in range(500):
        mujoco.mj_step(m, d)
    assert d.body("Cube").xpos[2] == pytest.approx(0.05, abs=0.01)  # resting on the floor


def test_simx_convert_prints_the_report(tmp_path, capsys):
    f = tmp_path / "cell.ttt"
    f.write_bytes(W.simple_scene())
    assert simx_convert([str(f), "-o", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert f"wrote {tmp_path / 'o' / 'cell.xml'}" in out
    bad = tmp_path / "bad.ttt"
    bad.write_bytes(b"VREP" + bytes(10))
    assert simx_convert([str(bad), "-o", str(tmp_path / "b")]) == 2
    assert "bad.ttt: record header" in capsys.readouterr().err


def test_proximity_volumes_become_settings(tmp_path):
    body = (W.cuboid_shape(1, -1, "Floor", (2, 2, 0.1), (0, 0, -0.05), dynamic=False)
            + W.proximity_sensor(2, -1, "Door", 30, 0.0, 0.2, (0.5, 1.3, 0.6, 1.4, 0, 0))
            + W.proximity_sensor(3, -1, "Tube", 31, 0.01, 0.3, (0, 0, 0, 0, 0.05, 0.08))
            + W.proximity_sensor(7, -1, "Octagon", 31, 0.0, 0.2, (0, 0, 0, 0, 0.02, 0.02), faces=8)
            + W.proximity_sensor(4, -1, "Fan", 32, 0.0, 0.4, angle=1.0)
            + W.proximity_sensor(5, -1, "Sonar", 33, 0.0, 0.4, angle=0.5)
            + W.proximity_sensor(6, -1, "Beam", 34, 0.0, 0.4))
    f = tmp_path / "sensors.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "sensors")
    texts = _settings(xml)
    assert texts["simx:Door"] == "volume=pyramid offset=0 size=0.5,1.3 size_far=0.6,1.4"
    # a cylinder's sides: the file's faceNumber (Ssi), else CConvexVolume's default 32
    assert texts["simx:Tube"] == "volume=cylinder offset=0.01 radius=0.05 radius_far=0.08 faces=32"
    assert texts["simx:Octagon"] == "volume=cylinder offset=0 radius=0.02 radius_far=0.02 faces=8"
    assert texts["simx:Fan"] == "volume=disc offset=0 angle=57.2958"
    assert texts["simx:Sonar"] == "angle=28.6479"
    assert "simx:Beam" not in texts
    assert not any("proximity" in line for line in report.lines())


def test_joint_targets_pid_and_spring_mode(tmp_path):
    def arm(h, name, x, **kw):
        return (W.cuboid_shape(h, -1, f"{name}_base", (0.1, 0.1, 0.1), (x, 0, 0.05), dynamic=False)
                + W.joint(h + 1, h, name, (0, 0, 0.1), **kw)
                + W.cuboid_shape(h + 2, h + 1, f"{name}_link", (0.3, 0.05, 0.05), (0.15, 0, 0), mass=0.2))

    body = (arm(1, "Wheel", 0.0, loop=False, target_velocity=2.0, extra=W.rec("Vaa", bytes([2])))
            + arm(4, "Servo", 1.0, extra=W.rec("Dpc", W.f32(0.5, 0, 0)) + W.rec("Dtp", W.f32(0.4)))
            # springs faster than their joints (target velocity 5 above the upper velocity 2):
            # the joints' own spring-dampers (tests/scene/ttt/test_ttt_spring_motor.py: slower ones)
            + arm(7, "Spring", 2.0, target_velocity=5.0, extra=W.rec("Dcm", W.i32(12)) + W.rec("Spp", W.f32(5.0, 0.5))
                  + W.rec("Dtp", W.f32(0.3)))
            + arm(10, "OldSpring", 3.0, spring=True, target_velocity=5.0,
                  extra=W.rec("Spp", W.f32(5.0, 0.5)) + W.rec("Dtp", W.f32(0.3))))
    f = tmp_path / "joints.ttt"
    no_gravity = W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, 0))))
    f.write_bytes(W.ttt_file(no_gravity + body))
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "joints")
    texts = _settings(xml)
    # Vaa bit 1: "lock motor when target velocity is zero" (RLBench's Panda fingers have it)
    assert texts["simx:Wheel"] == "mode=velocity max_velocity=2 target_velocity=2 velocity_lock=1"
    assert texts["simx:Servo"] == "mode=position max_velocity=2 pid_p=0.5 target_position=0.400000006"
    # a <= 4.3 file marks spring mode by Va9 bit 7 (RLBench's weighing scales' tray)
    assert texts["simx:Spring"] == texts["simx:OldSpring"] == "mode=passive"
    m = mujoco.MjModel.from_xml_path(str(xml))
    for name in ("Spring", "OldSpring"):
        j = m.joint(name)
        assert m.jnt_stiffness[j.id] == pytest.approx(5.0) and m.dof_damping[j.dofadr[0]] == pytest.approx(0.5)
        assert m.qpos_spring[j.qposadr[0]] == pytest.approx(0.3)
    assert "spring" not in " ".join(report.lines())
    # the scene runs as V-REP ran it: the wheel turns at its target velocity, the servo reaches
    # its target, the spring holds the link at its rest position
    from simx_server.scene.simulation import Simulation
    sim = Simulation(xml, realtime=False)
    try:
        assert sim.world.motors.pid_p[sim.world.motor_index[sim.world.resolve("Servo").handle]] == 0.5
        locked = sim.world.motors.locked
        assert locked[sim.world.motor_index[sim.world.resolve("Wheel").handle]]
        assert not locked[sim.world.motor_index[sim.world.resolve("Servo").handle]]
        sim.start()
        for _ in range(10):  # 0.5 s (the wheel's range ends at 1.5 rad)
            sim.step()
        d = sim.world.data
        assert d.joint("Wheel").qvel[0] == pytest.approx(2.0, abs=0.05)
        for _ in range(30):
            sim.step()
        assert d.joint("Servo").qpos[0] == pytest.approx(0.4, abs=0.01)
        assert d.joint("Spring").qpos[0] == pytest.approx(0.3, abs=0.01)
        assert d.joint("OldSpring").qpos[0] == pytest.approx(0.3, abs=0.01)
    finally:
        sim.close()


def test_textures_without_coordinates_are_projected_as_vrep_maps_them(tmp_path):
    rgb = np.zeros((8, 8, 3), np.uint8)
    rgb[:4] = 255
    body = (W.texture(7, "tiles", rgb)
            + W.cuboid_shape(1, -1, "Floor", (2, 1, 0.1), (0, 0, -0.05), dynamic=False,
                             texture=W.texture_link(7, 0, (1.0, 0.5)))  # planar: 1 m x 0.5 m tiles
            + W.cuboid_shape(2, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.3),
                             texture=W.texture_link(7, 3, (0.2, 0.2))))  # cube: one texture per face
    f = tmp_path / "textured.ttt"
    f.write_bytes(W.ttt_file(body))
    out = tmp_path / "out"
    xml, report = convert.convert(reader.read(f), out, "textured")
    assert not any("texture" in line for line in report.lines())
    m = mujoco.MjModel.from_xml_path(str(xml))
    for body_name in ("Floor", "Crate"):
        geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == m.body(body_name).id]
        kinds = sorted((int(m.geom_type[g]), int(m.geom_contype[g]) > 0, int(m.geom_group[g]), int(m.geom_matid[g]) >= 0)
                       for g in geoms)
        # the primitive collides, hidden (group 3); its textured triangles are what is seen
        assert kinds == [(int(mujoco.mjtGeom.mjGEOM_BOX), True, 3, False), (int(mujoco.mjtGeom.mjGEOM_MESH), False, 0, True)]

    def coordinates(obj):
        return {tuple(float(x) for x in line.split()[1:]) for line in obj.read_text().splitlines()
                if line.startswith("vt ")}

    floor, crate = sorted((out / "meshes").glob("*.obj"))
    # planar along z: corners (+-1, +-0.5) of the floor at u = x / 1 + 0.5, v = y / 0.5 + 0.5
    assert coordinates(floor) == {(u, v) for u in (-0.5, 1.5) for v in (-0.5, 1.5)}
    # cube: each face projected along its own axis, the 0.2 m crate on one 0.2 m texture
    assert coordinates(crate) == {(u, v) for u in (0.0, 1.0) for v in (0.0, 1.0)}


def test_old_ik_groups_keep_every_element(tmp_path):
    body = (W.cuboid_shape(1, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.joint(2, 1, "J1", (0, 0, 0.15)) + W.cuboid_shape(3, 2, "L1", (0.05, 0.05, 0.3), (0, 0, 0.15), mass=0.5)
            + W.joint(4, 3, "J2", (0, 0, 0.15)) + W.cuboid_shape(5, 4, "L2", (0.05, 0.05, 0.3), (0, 0, 0.15), mass=0.5)
            + W.dummy(6, 5, "Tip", (0, 0, 0.15), linked=7, link_type=0) + W.dummy(7, -1, "Target", (0.1, 0, 0.5), linked=6)
            + W.dummy(8, 5, "TipO", (0, 0, 0.0), linked=9, link_type=0) + W.dummy(9, -1, "TargetO", (0, 0, 0.5), linked=8)
            + W.ik_group("Arm", [(6, 1, 7), (8, 1, 16)]))
    f = tmp_path / "ik.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "ik")
    # CIkElement_old's and _CIkGroup_old's defaults where the file has none
    assert _settings(xml)["simx:ik:Arm"] == ("tip=Tip target=Target constraints=position base=Base "
                                             "precision=0.0005,0.00174532925 "
                                             "tip2=TipO target2=TargetO constraints2=16 base2=Base "
                                             "precision2=0.0005,0.00174532925 "
                                             "method=pseudo_inverse damping=0.1 iterations=3 max_steps=false")
    assert not any("IK group" in line for line in report.lines())
    from simx_server.scene.simulation import Simulation
    from simx_server.sim import ik
    sim = Simulation(xml, realtime=False)
    try:
        group = ik.groups(sim.world).group("Arm")
        assert [e.constraints for e in group.elements] == [7, 16] and len(group.joints) == 2
    finally:
        sim.close()


def test_ik_group_explicit_handling_is_var_bit_6(tmp_path):
    """CIkGroup::serialize keeps "explicit handling" in bit 6 of "Var" (bit 0: active); PyRep's
    arms' groups are explicit, solved only when asked, and a group of an explicit "Var" is read so
    even when "Va2" (joint-limit correction) has bit 1 set."""
    body = (W.cuboid_shape(1, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.joint(2, 1, "J1", (0, 0, 0.15)) + W.cuboid_shape(3, 2, "L1", (0.05, 0.05, 0.3), (0, 0, 0.15), mass=0.5)
            + W.dummy(6, 3, "Tip", (0, 0, 0.15), linked=7, link_type=0) + W.dummy(7, -1, "Target", (0.1, 0, 0.5), linked=6))
    for explicit in (False, True):
        f = tmp_path / f"ik{explicit}.ttt"
        f.write_bytes(W.ttt_file(body + W.ik_group("Arm", [(6, 1, 7)], explicit=explicit)))
        assert reader.read(f).ik_groups[0].explicit is explicit


def test_joint_max_velocity_is_the_last_saved_of_4_4s_and_4_3s(tmp_path):
    """CoppeliaSim 4.4+ saves a joint's max velocity, acceleration and jerk (``_uc``, doubles;
    ``Ruc``, floats) and reads 4.3's upper velocity limit (``Ulv``) only for a dynamic joint;
    ``CJoint::serialize`` loads them in file order, the last one counts. The position loop
    runs no faster than that velocity (the UR3 of issue 50: 180 deg/s for joints 1-3, 360 for 4-6)."""
    import struct

    def arm(h, name, x, **kw):
        return (W.cuboid_shape(h, -1, f"{name}_base", (0.1, 0.1, 0.1), (x, 0, 0.05), dynamic=False)
                + W.joint(h + 1, h, name, (0, 0, 0.1), **kw)
                + W.cuboid_shape(h + 2, h + 1, f"{name}_link", (0.3, 0.05, 0.05), (0.15, 0, 0), mass=0.2))

    uc = W.rec("_uc", struct.pack("<3d", 6.25, 12.5, 25.0))
    body = (arm(1, "Wrist", 0.0, extra=uc)  # written after Ulv (2.0): 4.4's value counts
            + arm(4, "Old", 1.0)  # Ulv only: 4.3's value
            + arm(7, "Ruc", 2.0, extra=W.rec("Ruc", W.f32(4.0, 8.0, 16.0))))
    f = tmp_path / "joints.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=41000))
    velocities = {o.name: o.data.max_velocity for o in reader.read(f).objects.values() if o.kind == "joint"}
    assert velocities == {"Wrist": 6.25, "Old": 2.0, "Ruc": 4.0}
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "joints")
    assert _settings(xml)["simx:Wrist"] == "mode=position max_velocity=6.25"


@pytest.mark.parametrize("text, customized", [
    ("-- The main script is not supposed to be modified, except in special cases.\nrequire('defaultMainScript')", False),
    ("--lua\n\nrequire 'defaultMainScript'\n", False),
    ("require('defaultMainScript')\nfunction sysCall_actuation() sim.handleDynamics(0.05) end", True),
    ("function sysCall_init() end", True),
])
def test_a_main_script_is_reported_only_when_not_the_default(tmp_path, text, customized):
    """CoppeliaSim 4.x saves its default main script as a comment and ``require('defaultMainScript')``
    (coppeliaSimLib ``DEFAULT_MAINSCRIPT_CODE``); simx runs its own main loop, so only a main
    script with code of its own is reported as not carried over."""
    f = tmp_path / "main.ttt"
    f.write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Box", (0.1, 0.1, 0.1), (0, 0, 0.05))
                             + W.script(0, -1, text, kind=0), serialization=25, program=41000))
    _, report = convert.convert(reader.read(f), tmp_path / "out", "main")
    assert ("customized main scripts" in " ".join(report.lines())) is customized
