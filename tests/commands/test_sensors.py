"""simx_server/sim/sensors.py, kinematics.py, collisions.py, group_data.py and object_params.py
in-process, on tests/scenes/sensors.xml (its comment lists the layout)."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from simx_client.protocol import ArgumentError, ObjectTypeError, UnknownObjectError, UnsupportedError
from simx_server.commands import collisions as cmd_collisions
from simx_server.commands import group_data as cmd_group_data
from simx_server.commands import joints as cmd_joints
from simx_server.commands import parameters as cmd_parameters
from simx_server.commands import sensors as cmd_sensors
from simx_server import commands
from simx_server.sim import sensors as S
from simx_server.scene.simulation import Simulation

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "sensors.xml"
G = 9.81
COS30, SIN30 = math.cos(math.radians(30)), math.sin(math.radians(30))


@pytest.fixture
def sim():
    s = Simulation(SCENE, dt=0.05, realtime=False)
    yield s
    s.close()


def H(sim, name):
    return sim.world.resolve(name).handle


def site_rot(sim, name):
    return sim.world.data.site_xmat[sim.world.resolve(name).mj_id].reshape(3, 3).copy()


def test_handlers_table_is_complete():
    tables = [(cmd_sensors.SENSOR_HANDLERS, cmd_sensors.SENSOR_IDENTITY_ARITY), (cmd_joints.KINEMATICS_HANDLERS, cmd_joints.KINEMATICS_IDENTITY_ARITY),
              (cmd_collisions.COLLISION_HANDLERS, cmd_collisions.COLLISION_IDENTITY_ARITY), (cmd_group_data.GROUP_DATA_HANDLERS, cmd_group_data.GROUP_DATA_IDENTITY_ARITY),
              (cmd_parameters.PARAM_HANDLERS, cmd_parameters.PARAM_IDENTITY_ARITY)]
    for handlers, arity in tables:
        assert set(handlers) == set(arity)
    names = [name for handlers, _ in tables for name in handlers]
    assert len(names) == len(set(names)) == 19
    assert set(names) <= set(commands.HANDLERS)


# ----------------------------------------------------------------- proximity sensor
@pytest.mark.renderers_on_demand  # no image read
def test_proximity_sensor_point_handle_normal_cutoff_and_nothing(sim):
    prox, target = H(sim, "prox"), H(sim, "target")
    detected, point, hit, normal = cmd_sensors.read_proximity_sensor(sim, [prox])
    gap = 1.0 - 0.1 / COS30  # ray along world +x from x=-1 meets the 30-degree-turned face
    assert detected is True and hit == target
    assert point == pytest.approx([0.0, 0.0, gap], abs=1e-9)
    expected = site_rot(sim, "prox").T @ np.array([-COS30, -SIN30, 0.0])  # outward face normal
    assert normal == pytest.approx(expected.tolist(), abs=1e-9)
    assert normal == pytest.approx([0.0, -0.5, -COS30], abs=1e-9)  # site z = world x

    slide = H(sim, "target_x")
    sim.world.set_joint_position(slide, 0.9)  # 1.78 m: inside the 2 m cutoff
    assert cmd_sensors.read_proximity_sensor(sim, [prox])[1][2] == pytest.approx(gap + 0.9, abs=1e-9)
    sim.world.set_joint_position(slide, 1.2)  # 2.08 m: beyond the rangefinder's cutoff
    assert cmd_sensors.read_proximity_sensor(sim, [prox]) == [False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]]
    sim.world.set_joint_position(slide, 5.0)
    assert cmd_sensors.read_proximity_sensor(sim, [prox])[0] is False
    with pytest.raises(ObjectTypeError):
        cmd_sensors.read_proximity_sensor(sim, [H(sim, "marker")])  # a plain dummy
    with pytest.raises(ArgumentError):
        cmd_sensors.read_proximity_sensor(sim, ["prox"])


# --------------------------------------------------------------------- force sensor
@pytest.mark.renderers_on_demand  # no image read
def test_force_sensor_reads_the_hanging_weight_and_its_moment(sim):
    ft = H(sim, "ft")
    sim.start()
    for _ in range(3):
        sim.step()
    state, force, torque = cmd_sensors.read_force_sensor(sim, [ft])
    assert state & S.FORCE_STATE_DATA and not state & S.FORCE_STATE_BROKEN
    # CoppeliaSim's sign: what the payload does to the mount, its weight, along gravity (-z here)
    assert force == pytest.approx([0.0, 0.0, -2.0 * G], abs=1e-6)  # 2 kg payload
    assert torque == pytest.approx([0.0, 2.0 * G * 0.1, 0.0], abs=1e-6)  # its COM 0.1 m along +x
    # MuJoCo's own force and torque sensors on the site read the reverse (the mount on the payload)
    d = sim.world.data
    assert np.allclose(d.sensor("ft_force").data, -np.array(force))
    assert np.allclose(d.sensor("ft_torque").data, -np.array(torque))

    cmd_sensors.break_force_sensor(sim, [ft])
    assert cmd_sensors.read_force_sensor(sim, [ft]) == [S.FORCE_STATE_BROKEN, [0.0] * 3, [0.0] * 3]
    assert cmd_group_data.get_object_group_data(sim, [12, 14])[1] == [S.FORCE_STATE_BROKEN]
    sim.stop()  # a stop restores the scene: the sensor works again
    assert cmd_sensors.read_force_sensor(sim, [ft])[0] == S.FORCE_STATE_DATA
    with pytest.raises(ObjectTypeError):
        cmd_sensors.break_force_sensor(sim, [H(sim, "payload")])


@pytest.mark.renderers_on_demand  # no image read
def test_mass_parameter_changes_the_measured_weight(sim):
    payload, ft = H(sim, "payload"), H(sim, "ft")
    assert cmd_parameters.get_object_float_parameter(sim, [payload, 3005]) == pytest.approx(2.0)
    sim.world.set_joint_position(H(sim, "target_x"), 0.3)  # away from qpos0
    q0 = sim.world.data.qpos.copy()
    cmd_parameters.set_object_float_parameter(sim, [payload, 3005, 4.0])
    assert np.array_equal(sim.world.data.qpos, q0)  # mj_setConst must not move anything
    assert cmd_parameters.get_object_float_parameter(sim, [payload, 3005]) == pytest.approx(4.0)
    assert cmd_sensors.read_force_sensor(sim, [ft])[1][2] == pytest.approx(-4.0 * G, abs=1e-6)
    with pytest.raises(ArgumentError):
        cmd_parameters.set_object_float_parameter(sim, [payload, 3005, -1.0])
    with pytest.raises(ObjectTypeError):
        cmd_parameters.get_object_float_parameter(sim, [ft, 3005])


# ---------------------------------------------------------------------------- joints
@pytest.mark.renderers_on_demand  # no image read
def test_joint_matrix_of_hinge_slide_and_ball(sim):
    w = sim.world
    w.set_joint_position(H(sim, "hinge"), 0.3)
    c, s = math.cos(0.3), math.sin(0.3)
    assert cmd_joints.get_joint_matrix(sim, [H(sim, "hinge")]) == pytest.approx(
        [c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0], abs=1e-12)
    w.set_joint_position(H(sim, "target_x"), 0.25)
    assert cmd_joints.get_joint_matrix(sim, [H(sim, "target_x")]) == pytest.approx(
        [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.25], abs=1e-12)
    assert cmd_joints.get_joint_matrix(sim, [H(sim, "ball")]) == pytest.approx(
        [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0], abs=1e-12)
    with pytest.raises(ObjectTypeError):
        cmd_joints.get_joint_matrix(sim, [H(sim, "hinge_link")])


def _rotation(axis, angle):
    q = np.empty(4)
    mujoco.mju_axisAngle2Quat(q, np.asarray(axis, float) / np.linalg.norm(axis), angle)
    r = np.empty(9)
    mujoco.mju_quat2Mat(r, q)
    return r.reshape(3, 3)


@pytest.mark.renderers_on_demand  # no image read
def test_spherical_joint_matrix_round_trip_moves_the_body(sim):
    ball = H(sim, "ball")
    rot = _rotation([1, 2, 3], 0.8)
    matrix = np.hstack([rot, [[9.0], [9.0], [9.0]]])  # the translation column is ignored
    version = sim.world.version
    assert cmd_joints.set_spherical_joint_matrix(sim, [ball, matrix.reshape(12).tolist()]) is None
    assert sim.world.version > version
    got = np.array(cmd_joints.get_joint_matrix(sim, [ball])).reshape(3, 4)
    assert np.allclose(got[:, :3], rot, atol=1e-9) and np.allclose(got[:, 3], 0)
    assert np.allclose(sim.world.frame(H(sim, "ball_link"))[1], rot, atol=1e-9)  # the body turned
    q = [cmd_parameters.get_object_float_parameter(sim, [ball, i]) for i in (2013, 2014, 2015, 2016)]
    assert abs(np.dot(q, sim.world.quaternion(H(sim, "ball_link"), -1))) == pytest.approx(1.0)
    # flat form: [h, m0 .. m11]
    cmd_joints.set_spherical_joint_matrix(sim, [ball, *np.hstack([rot.T, np.zeros((3, 1))]).reshape(12).tolist()])
    assert np.allclose(np.array(cmd_joints.get_joint_matrix(sim, [ball])).reshape(3, 4)[:, :3], rot.T, atol=1e-9)
    with pytest.raises(ObjectTypeError):
        cmd_joints.set_spherical_joint_matrix(sim, [H(sim, "hinge"), matrix.reshape(12).tolist()])
    with pytest.raises(ArgumentError):
        cmd_joints.set_spherical_joint_matrix(sim, [ball, [1.0] * 12])  # not a rotation
    with pytest.raises(ArgumentError):
        cmd_joints.set_spherical_joint_matrix(sim, [ball, [1.0] * 9])
    with pytest.raises(ArgumentError):
        cmd_joints.set_spherical_joint_matrix(sim, [ball, [float("nan")] * 12])


# ---------------------------------------------------------------- collision, distance
@pytest.mark.renderers_on_demand  # no image read
def test_collision_touching_and_separated(sim):
    a, b, c = H(sim, "blockA"), H(sim, "blockB"), H(sim, "blockC")
    assert cmd_collisions.check_collision(sim, [a, c]) is True  # overlap 0.01 m (two static bodies)
    assert cmd_collisions.check_collision(sim, [a, b]) is False  # 0.05 m apart
    assert cmd_collisions.check_collision(sim, [a, -2]) is True
    assert cmd_collisions.check_collision(sim, [b, -2]) is False  # floor and C are out of reach too
    touching = cmd_collisions.get_collision_handle(sim, ["touching"])
    apart = cmd_collisions.get_collision_handle(sim, ["apart#"])
    assert (touching, apart) == (1, 2)
    assert cmd_collisions.read_collision(sim, [touching]) is True and cmd_collisions.read_collision(sim, [apart]) is False
    with pytest.raises(UnknownObjectError):
        cmd_collisions.get_collision_handle(sim, ["gapAB"])  # a distance object, other namespace
    with pytest.raises(UnknownObjectError):
        cmd_collisions.read_collision(sim, [99])
    with pytest.raises(ArgumentError, match="malformed"):
        cmd_collisions.read_collision(sim, [cmd_collisions.get_collision_handle(sim, ["malformed"])])
    with pytest.raises(ObjectTypeError):
        cmd_collisions.check_collision(sim, [H(sim, "marker"), a])  # a dummy is not collidable
    # not respondable (contype=conaffinity=0) but collidable, as V-REP's shapes: tested all the same
    assert cmd_collisions.check_collision(sim, [H(sim, "target"), a]) is False
    with pytest.raises(ArgumentError):
        cmd_collisions.check_collision(sim, [-2, a])


def test_distance_equals_the_known_gaps(sim):
    a, b, c, ball = H(sim, "blockA"), H(sim, "blockB"), H(sim, "blockC"), H(sim, "ball_above")
    assert cmd_collisions.check_distance(sim, [a, b]) == pytest.approx(0.05, abs=1e-3)
    assert cmd_collisions.check_distance(sim, [a, c]) == 0.0  # overlapping: no penetration depth
    to_c = math.hypot(0.3, 0.01) - 0.1  # sphere centre to C's nearest edge, minus its radius
    assert cmd_collisions.check_distance(sim, [ball, -2]) == pytest.approx(to_c, abs=1e-3)
    assert cmd_collisions.check_distance(sim, [ball, a]) == pytest.approx(math.hypot(0.3, 0.2) - 0.1, abs=1e-3)
    gap = cmd_collisions.get_distance_handle(sim, ["gapAB"])
    assert cmd_collisions.read_distance(sim, [gap]) == pytest.approx(0.05, abs=1e-3)
    assert cmd_collisions.read_distance(sim, [cmd_collisions.get_distance_handle(sim, ["ballToAll"])]) == pytest.approx(to_c, abs=1e-3)
    with pytest.raises(UnknownObjectError, match="nosuchbody"):
        cmd_collisions.read_distance(sim, [cmd_collisions.get_distance_handle(sim, ["dangling"])])
    with pytest.raises(UnknownObjectError):
        cmd_collisions.get_distance_handle(sim, ["nope"])
    with pytest.raises(ArgumentError):
        cmd_collisions.check_distance(sim, [a, a])


# ------------------------------------------------------------------------ velocities
@pytest.mark.renderers_on_demand  # no image read
def test_velocity_of_a_falling_body_is_g_t(sim):
    faller = H(sim, "faller")
    for _ in range(10):  # 0.5 s
        sim.world.step()
    t = sim.world.time
    v, w = cmd_joints.get_object_velocity(sim, [faller])
    assert v == pytest.approx([0.0, 0.0, -G * t], abs=1e-9)  # not one substep behind
    assert w == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    assert cmd_parameters.get_object_float_parameter(sim, [faller, 13]) == pytest.approx(-G * t, abs=1e-9)
    handles, _, floats, _ = cmd_group_data.get_object_group_data(sim, [0, 19])
    i = handles.index(faller)
    assert floats[6 * i:6 * i + 6] == pytest.approx(v + w, abs=1e-12)


@pytest.mark.renderers_on_demand  # no image read
def test_velocity_of_a_turning_body_and_points_on_it(sim):
    d, m = sim.world.data, sim.world.model
    d.qvel[m.jnt_dofadr[sim.world.resolve("hinge").mj_id]] = 2.0  # about world y
    sim.world.changed()  # a state change
    v, w = cmd_joints.get_object_velocity(sim, [H(sim, "hinge_link")])
    assert w == pytest.approx([0.0, 2.0, 0.0], abs=1e-12) and v == pytest.approx([0, 0, 0], abs=1e-12)
    assert cmd_parameters.get_object_float_parameter(sim, [H(sim, "hinge_link"), 14]) == pytest.approx(2.0)
    assert cmd_parameters.get_object_float_parameter(sim, [H(sim, "hinge"), 2012]) == pytest.approx(2.0)
    d.qvel[m.jnt_dofadr[sim.world.resolve("target_x").mj_id]] = 0.7
    sim.world.changed()
    assert cmd_joints.get_object_velocity(sim, [H(sim, "target")])[0] == pytest.approx([0.7, 0, 0], abs=1e-12)


# ------------------------------------------------------------------------ group data
def test_group_data_shapes_and_values(sim):
    w = sim.world
    n = len(w.objects)
    handles, ints, floats, strings = cmd_group_data.get_object_group_data(sim, [-2, 0])
    assert handles == cmd_group_data.get_object_group_data(sim, [109, 0])[0] and len(handles) == n
    assert strings == [w.objects[h].name for h in handles] and ints == [] and floats == []
    assert cmd_group_data.get_object_group_data(sim, [-2, 1])[1] == [w.objects[h].type for h in handles]
    assert cmd_group_data.get_object_group_data(sim, [-2, 2])[1] == [w.objects[h].parent for h in handles]
    for data_type, per in ((3, 3), (5, 3), (7, 4), (9, 6), (11, 7), (19, 6)):
        assert len(cmd_group_data.get_object_group_data(sim, [-2, data_type])[2]) == per * n, data_type
    shapes, _, pos, _ = cmd_group_data.get_object_group_data(sim, [0, 4])
    i = shapes.index(H(sim, "payload"))
    assert pos[3 * i:3 * i + 3] == pytest.approx([0.0, 0.0, -0.2])  # relative to its parent
    # sensors are sites: their poses are the sites' (World.frame alone gets them wrong)
    sensors, _, pose, _ = cmd_group_data.get_object_group_data(sim, [5, 11])
    assert sensors == [H(sim, "prox")]
    assert pose[:3] == pytest.approx([-1.0, 0.0, 0.5])
    prox_ints, prox_floats = cmd_group_data.get_object_group_data(sim, [5, 13])[1:3]
    detected, point, hit, normal = cmd_sensors.read_proximity_sensor(sim, [H(sim, "prox")])
    assert prox_ints == [1, hit] and prox_floats == pytest.approx(point + normal)
    joints, jints, jfloats, _ = cmd_group_data.get_object_group_data(sim, [1, 16])
    assert jints == [11, 5, 10, 5, 12, 5]  # target_x prismatic, hinge revolute, ball spherical
    assert jfloats[2:4] == [-math.pi, -1.0]  # unlimited hinge: V-REP's cyclic
    assert len(cmd_group_data.get_object_group_data(sim, [1, 15])[2]) == 2 * len(joints)
    assert cmd_group_data.get_object_group_data(sim, [-2, 21])[3][handles.index(H(sim, "ft"))] == "/mount/payload/ft"
    assert cmd_group_data.get_object_group_data(sim, [3, 0]) == [[], [], [], []]  # no cameras-as-cameras
    with pytest.raises(UnsupportedError, match="dataType 22"):
        cmd_group_data.get_object_group_data(sim, [-2, 22])
    with pytest.raises(UnsupportedError, match="objectType 115"):
        cmd_group_data.get_object_group_data(sim, [115, 0])


# ------------------------------------------------------------------------- vision
def test_vision_packet_matches_the_image_and_depth(sim):
    cam = H(sim, "cam")
    detected, packets = cmd_sensors.read_vision_sensor(sim, [cam]).future.result()  # rendered later
    assert detected is False and len(packets) == 1 and len(packets[0]) == 15
    img = sim.vision.image(cam, False).astype(np.int64)
    depth = sim.vision.depth(cam).astype(float)
    # V-REP 3.x's integer arithmetic: intensity (R + G + B) // 3, averages truncated, / 255
    channels = [img.sum(axis=2) // 3, img[..., 0], img[..., 1], img[..., 2]]
    expected = ([c.min() / 255 for c in channels] + [depth.min()] + [c.max() / 255 for c in channels]
                + [depth.max()] + [(c.sum() // c.size) / 255 for c in channels] + [depth.mean()])
    assert packets[0] == pytest.approx(expected, abs=1e-6)
    rgb = img / 255.0
    assert rgb.max() > 0.5 and depth.min() < depth.max()  # the scene is in view, not blank
    with pytest.raises(ObjectTypeError):
        cmd_sensors.read_vision_sensor(sim, [H(sim, "prox")])


def test_image_size_is_the_size_of_what_the_handlers_return(sim):
    """commands.sensors.image_size, known before rendering, equals the bytes of the reply."""
    cam = H(sim, "cam")
    for name, args in [("GetVisionSensorImage", [cam, 0]), ("GetVisionSensorImage", [cam, 1]),
                       ("GetVisionSensorDepthBuffer", [cam])]:
        (w, h), data = cmd_sensors.IMAGE_HANDLERS[name](sim, args).future.result()
        assert cmd_sensors.image_size(sim, name, args) == len(data) > 0
        assert cmd_sensors.image_pixels(sim, args) == w * h
    assert cmd_sensors.IMAGES == {"GetVisionSensorImage", "GetVisionSensorDepthBuffer"}
    assert cmd_sensors.image_size(sim, "GetVisionSensorImage", [H(sim, "prox"), 0]) == 0  # no vision sensor
    assert cmd_sensors.image_size(sim, "GetVisionSensorImage", ["cam", 0]) == 0  # the handler answers the error


def test_passive_sensor_image_set_get_and_packet(sim):
    passive, cam = H(sim, "passive"), H(sim, "cam")
    assert S.is_passive(sim, passive) and not S.is_passive(sim, cam)
    assert S.override_image(sim, cam, False) is None  # rendered sensors: the lead renders
    assert not S.override_image(sim, passive, False).any()  # nothing written yet: black
    img = np.arange(6 * 8 * 3, dtype=np.uint8).reshape(6, 8, 3)
    cmd_sensors.set_vision_sensor_image(sim, [passive, img.tobytes(), 0])
    assert np.array_equal(S.override_image(sim, passive, False), img)
    assert np.array_equal(S.override_image(sim, passive, True), img.astype(int).sum(axis=2) // 3)
    packet = cmd_sensors.read_vision_sensor(sim, [passive]).future.result()[1][0]
    assert packet[1:4] == pytest.approx([0.0, 1 / 255, 2 / 255])  # R, G, B minima
    assert packet[6:9] == pytest.approx([141 / 255, 142 / 255, 143 / 255])  # maxima
    # average intensity: V-REP's integer mean of the per-pixel (R + G + B) // 3
    assert packet[10] == pytest.approx((img.astype(int).sum(axis=2) // 3).sum() // 48 / 255)
    grey = bytes(range(48))
    cmd_sensors.set_vision_sensor_image(sim, [passive, list(grey), 1])  # a list of ints, grey
    assert np.array_equal(S.override_image(sim, passive, True), np.arange(48).reshape(6, 8))
    with pytest.raises(ArgumentError, match="needs 144"):
        cmd_sensors.set_vision_sensor_image(sim, [passive, bytes(48), 0])
    with pytest.raises(ObjectTypeError, match="not passive"):
        cmd_sensors.set_vision_sensor_image(sim, [cam, bytes(32 * 24 * 3), 0])
    with pytest.raises(ArgumentError):
        cmd_sensors.set_vision_sensor_image(sim, [passive, [300] * 48, 1])


def test_vision_parameters_and_their_errors(sim):
    cam = H(sim, "cam")
    get_f = lambda pid: cmd_parameters.get_object_float_parameter(sim, [cam, pid])  # noqa: E731
    assert (get_f(1000), get_f(1001)) == (0.5, 5.0)
    assert [cmd_parameters.get_object_int_parameter(sim, [cam, p]) for p in (1002, 1003)] == [32, 24]
    horizontal = 2 * math.atan(math.tan(math.radians(22.5)) * 32 / 24)  # 32 > 24: the wider angle
    assert get_f(1004) == pytest.approx(horizontal)
    cmd_parameters.set_object_float_parameter(sim, [cam, 1004, 1.2])
    assert get_f(1004) == pytest.approx(1.2)
    assert sim.world.model.cam_fovy[sim.vision.spec(cam).camera] == pytest.approx(
        math.degrees(2 * math.atan(math.tan(0.6) * 24 / 32)))

    metres = sim.vision.depth(cam) * 4.5 + 0.5  # near 0.5, far 5
    cmd_parameters.set_object_float_parameter(sim, [cam, 1000, 1.0])
    cmd_parameters.set_object_float_parameter(sim, [cam, 1001, 4.0])
    assert np.allclose(sim.vision.depth(cam), np.clip((metres - 1.0) / 3.0, 0, 1), atol=1e-5)
    with pytest.raises(ArgumentError):
        cmd_parameters.set_object_float_parameter(sim, [cam, 1000, 4.5])  # near beyond far
    cmd_parameters.set_object_int_parameter(sim, [cam, 1002, 64])  # settable at run time, as in V-REP
    assert cmd_parameters.get_object_int_parameter(sim, [cam, 1002]) == 64
    with pytest.raises(ArgumentError, match="1002"):
        cmd_parameters.set_object_int_parameter(sim, [cam, 1002, 0])
    with pytest.raises(UnsupportedError, match="int parameter"):
        cmd_parameters.get_object_float_parameter(sim, [cam, 1002])
    with pytest.raises(UnsupportedError, match="1016"):  # POV-Ray blur samples
        cmd_parameters.get_object_int_parameter(sim, [cam, 1016])
    assert cmd_parameters.get_object_int_parameter(sim, [cam, 1017]) == 0  # render mode: OpenGL (tests/sim/test_handle_render.py)
    with pytest.raises(UnsupportedError, match="read-only"):
        cmd_parameters.set_object_float_parameter(sim, [cam, 11, 1.0])
    with pytest.raises(ObjectTypeError):
        cmd_parameters.get_object_float_parameter(sim, [H(sim, "blockA"), 1000])
    with pytest.raises(UnknownObjectError):
        cmd_parameters.get_object_float_parameter(sim, [999, 1000])


@pytest.mark.renderers_on_demand  # no image read
def test_joint_and_shape_parameters(sim):
    hinge, ball = H(sim, "hinge"), H(sim, "ball")
    assert cmd_parameters.get_object_float_parameter(sim, [hinge, 2017]) == 1.5
    cmd_parameters.set_object_float_parameter(sim, [hinge, 2017, 0.5])
    assert sim.world.max_velocity[sim.world.motor(hinge)] == 0.5
    with pytest.raises(ObjectTypeError):
        cmd_parameters.get_object_float_parameter(sim, [ball, 2017])  # no motor
    assert cmd_parameters.get_object_float_parameter(sim, [hinge, 2002]) == 0.1  # V-REP's default P gain
    with pytest.raises(UnsupportedError, match="proportional"):
        cmd_parameters.set_object_float_parameter(sim, [hinge, 2003, 0.1])
    assert [cmd_parameters.get_object_int_parameter(sim, [hinge, p]) for p in (2000, 2001)] == [1, 1]
    assert [cmd_parameters.get_object_int_parameter(sim, [ball, p]) for p in (2000, 2001)] == [0, 0]
    cmd_parameters.set_object_int_parameter(sim, [hinge, 2001, 0])  # control loop off: velocity control
    assert cmd_parameters.get_object_int_parameter(sim, [hinge, 2001]) == 0
    sim.world.set_joint_target_velocity(hinge, 1.0)  # stored in any mode, as V-REP does
    with pytest.raises(ArgumentError):
        cmd_parameters.set_object_int_parameter(sim, [hinge, 2001, 2])
    a = H(sim, "blockA")
    bbox = [cmd_parameters.get_object_float_parameter(sim, [a, p]) for p in range(15, 21)]
    assert bbox == pytest.approx([-0.1, -0.1, -0.1, 0.1, 0.1, 0.1])
    assert cmd_parameters.get_object_int_parameter(sim, [a, 3003]) == 1  # welded to the world
    assert cmd_parameters.get_object_int_parameter(sim, [H(sim, "faller"), 3003]) == 0
    assert cmd_parameters.get_object_int_parameter(sim, [H(sim, "target"), 3004]) == 0  # contype 0
    # Static / respondable switch at run time through the legacy command too (a rebuild for
    # static, the contact bits for respondable; any nonzero value is 1, as CoppeliaSim's)
    cmd_parameters.set_object_int_parameter(sim, [H(sim, "faller"), 3003, 0])  # already so
    cmd_parameters.set_object_int_parameter(sim, [H(sim, "faller"), 3003, 1])
    assert cmd_parameters.get_object_int_parameter(sim, [H(sim, "faller"), 3003]) == 1
    cmd_parameters.set_object_int_parameter(sim, [H(sim, "target"), 3004, 7])
    assert cmd_parameters.get_object_int_parameter(sim, [H(sim, "target"), 3004]) == 1
    with pytest.raises(UnsupportedError, match="joints"):
        cmd_parameters.set_object_int_parameter(sim, [H(sim, "hinge_link"), 3003, 1])  # on a hinge
    with pytest.raises(UnsupportedError, match="3006"):
        cmd_parameters.get_object_float_parameter(sim, [a, 3006])
