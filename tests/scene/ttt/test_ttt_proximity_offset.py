"""A ray-type proximity sensor's offset (issue 50, a LumiBot whose sensors sit inside its own
cover): CoppeliaSim casts the ray from ``offset`` along +z, ``range`` long
(coppeliaSimLib ``CProxSensorRoutine::_detectShape``, ray branch, through
``geom_raySensorDetectMeshIfSmaller``), and reports the distance from the sensor's origin; what
lies nearer than the offset is not seen."""

from __future__ import annotations

import pytest

import tttwriter as W
from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read


def _scene(tmp_path) -> Simulation:
    """A static 0.1 m cover around two upward ray sensors at z = 1 (its top face 0.05 m above
    them), a static wall whose underside is 0.3 m above them: ``Eye`` with V-REP's default ray
    (offset 0.1 m, range 0.4 m), ``Bare`` with no offset."""
    no_gravity = W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, 0))))
    body = (no_gravity
            + W.cuboid_shape(1, -1, "Cover", (0.1, 0.1, 0.1), (0, 0, 1), dynamic=False)
            + W.cuboid_shape(2, -1, "Wall", (1, 1, 0.1), (0, 0, 1.35), dynamic=False)
            + W.proximity_sensor(3, -1, "Eye", kind=34, offset=0.1, reach=0.4, pos=(0, 0, 1))
            + W.proximity_sensor(4, -1, "Bare", kind=34, offset=0.0, reach=0.5, pos=(0.02, 0, 1)))
    f = tmp_path / "eye.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=40700))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "eye")
    return Simulation(xml, realtime=False)


def test_a_ray_sensor_does_not_see_what_lies_nearer_than_its_offset(tmp_path):
    sim = _scene(tmp_path)
    try:
        api = client_context(sim).sim
        cover, wall = api.getObject("/Cover"), api.getObject("/Wall")
        assert sim.world.resolve("Eye").settings.get("offset") == "0.1"
        # no offset: the cover's top face, seen from inside, 0.05 m away
        res, dist, point, hit, _ = api.readProximitySensor(api.getObject("/Bare"))
        assert (res, hit) == (1, cover) and dist == pytest.approx(0.05, abs=1e-6)
        # offset 0.1 m: the ray starts beyond the cover; the wall, 0.3 m from the sensor's origin
        res, dist, point, hit, normal = api.readProximitySensor(api.getObject("/Eye"))
        assert (res, hit) == (1, wall)
        assert dist == pytest.approx(0.3, abs=1e-6) and point == pytest.approx([0, 0, 0.3], abs=1e-6)
        assert normal == pytest.approx([0, 0, -1], abs=1e-6)
    finally:
        sim.close()


def test_the_offset_ray_ends_at_offset_plus_range(tmp_path):
    sim = _scene(tmp_path)
    try:
        api = client_context(sim).sim
        eye = api.getObject("/Eye")
        api.setObjectPosition(api.getObject("/Wall"), -1, [0, 0, 1.49])  # underside 0.44 m: in reach
        assert api.readProximitySensor(eye)[:2] == (1, pytest.approx(0.44, abs=1e-6))
        api.setObjectPosition(api.getObject("/Wall"), -1, [0, 0, 1.56])  # underside 0.51 m: beyond 0.5
        assert api.readProximitySensor(eye)[0] == 0
    finally:
        sim.close()


def test_create_proximity_sensor_keeps_a_ray_offset(tmp_path):
    """``sim.createProximitySensor``'s floatParams[0] is the offset (CoppeliaSim's
    ``CConvexVolume::setOffset``); a ray made with one starts there."""
    sim = _scene(tmp_path)
    try:
        api = client_context(sim).sim
        made = api.createProximitySensor(api.proximitysensor_ray, 16, 0, [0] * 8, [0.1, 0.4] + [0.0] * 13)
        api.setObjectPosition(made, -1, [-0.02, 0, 1])
        res, dist, _, hit, _ = api.readProximitySensor(made)
        assert (res, hit) == (1, api.getObject("/Wall")) and dist == pytest.approx(0.3, abs=1e-6)
    finally:
        sim.close()


def _cone_scene(tmp_path) -> Simulation:
    """The cover and wall of :func:`_scene` above an upward 30-degree cone sensor ``Sonar`` whose
    apex lies 0.05 m up its axis (offset), seeing from 0.1 m (radius) to 0.3 m from the apex."""
    no_gravity = W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, 0))))
    body = (no_gravity
            + W.cuboid_shape(1, -1, "Cover", (0.1, 0.1, 0.1), (0, 0, 1), dynamic=False)
            + W.cuboid_shape(2, -1, "Wall", (1, 1, 0.1), (0, 0, 1.35), dynamic=False)
            + W.proximity_sensor(3, -1, "Sonar", kind=33, offset=0.05, reach=0.2, sizes=(0, 0, 0, 0, 0.1, 0),
                                 angle=0.5236, pos=(0, 0, 1))
            + W.dummy(4, -1, "Close", (0, 0, 1.1)) + W.dummy(5, -1, "Far", (0, 0, 1.25)))
    f = tmp_path / "sonar.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=40700))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "sonar")
    return Simulation(xml, realtime=False)


def test_a_cone_sees_from_its_radius_around_its_offset_apex(tmp_path):
    """coppeliaSimLib ``CConvexVolume`` (cone): the apex ``offset`` up the axis, the volume
    between ``radius`` and ``radius + range`` from it; distances from the sensor's origin."""
    sim = _cone_scene(tmp_path)
    try:
        api = client_context(sim).sim
        sonar, wall = api.getObject("/Sonar"), api.getObject("/Wall")
        settings = sim.world.resolve("Sonar").settings
        assert (settings["offset"], settings["radius"]) == ("0.05", "0.1")
        # the cover's top face (0.05 m from the apex) lies within the radius: the wall is heard
        res, dist, point, hit, _ = api.readProximitySensor(sonar)
        assert (res, hit) == (1, wall) and dist == pytest.approx(0.3, abs=1e-6)
        assert point == pytest.approx([0, 0, 0.3], abs=1e-6)
        api.setObjectPosition(wall, -1, [0, 0, 1.39])  # underside 0.34 m from the origin, 0.29 from the apex
        assert api.readProximitySensor(sonar)[:2] == (1, pytest.approx(0.34, abs=1e-6))
        api.setObjectPosition(wall, -1, [0, 0, 1.41])  # 0.31 m from the apex: beyond radius + range
        assert api.readProximitySensor(sonar)[0] == 0
    finally:
        sim.close()


def test_a_cone_sees_a_dummy_only_beyond_its_radius(tmp_path):
    """``sim.checkProximitySensor`` of a dummy (``CProxSensorRoutine::_detectDummy``): its origin
    must lie in the cone's volume, beyond the radius from the apex."""
    sim = _cone_scene(tmp_path)
    try:
        api = client_context(sim).sim
        sonar = api.getObject("/Sonar")
        assert api.checkProximitySensor(sonar, api.getObject("/Close"))[0] == 0  # 0.05 m from the apex
        result, dist, _ = api.checkProximitySensor(sonar, api.getObject("/Far"))  # 0.2 m from the apex
        assert result == 1 and dist == pytest.approx(0.25, abs=1e-6)
    finally:
        sim.close()


def test_create_proximity_sensor_makes_a_cone_with_an_offset_and_a_radius(tmp_path):
    """floatParams[0] offset, [1] range, [7] radius, [9] angle (``sim.createProximitySensor``)."""
    sim = _cone_scene(tmp_path)
    try:
        api = client_context(sim).sim
        params = [0.05, 0.2, 0, 0, 0, 0, 0, 0.1, 0, 0.5236] + [0.0] * 5
        made = api.createProximitySensor(api.proximitysensor_cone, 16, 0, [0] * 8, params)
        api.setObjectPosition(made, -1, [0.01, 0, 1])
        res, dist, _, hit, _ = api.readProximitySensor(made)
        assert (res, hit) == (1, api.getObject("/Wall")) and dist == pytest.approx(0.3, abs=1e-4)
    finally:
        sim.close()


def test_check_proximity_sensor_ex2_rays_start_at_the_offset(tmp_path):
    """``sim.checkProximitySensorEx2`` on given triangles: the same ray, from its offset on."""
    sim = _scene(tmp_path)
    try:
        api = client_context(sim).sim
        eye = api.getObject("/Eye")

        def square(z: float) -> list[float]:  # two triangles facing down at height z, 0.2 m wide
            a, b, c, e = [-0.1, -0.1, z], [0.1, -0.1, z], [0.1, 0.1, z], [-0.1, 0.1, z]
            return a + c + b + a + e + c

        assert api.checkProximitySensorEx2(eye, square(1.05), 2, 2, 3, 5.0, 0)[0] == 0  # within the offset
        res, dist, point, normal = api.checkProximitySensorEx2(eye, square(1.05) + square(1.2), 2, 4, 3, 5.0, 0)
        assert res == 1 and dist == pytest.approx(0.2, abs=1e-9) and point == pytest.approx([0, 0, 0.2], abs=1e-9)
        assert api.checkProximitySensorEx2(eye, square(1.2), 2, 2, 3, 0.15, 0)[0] == 0  # beyond the threshold
    finally:
        sim.close()


def test_a_pyramid_volume_behind_its_origin_sees_there(tmp_path):
    """RLBench's light_bulb_out ``success`` sensor: a pyramid with offset -0.015 m and range
    0.01 m sees only between 0.015 and 0.005 m below its origin (``CConvexVolume::setOffset``
    takes -1000..1000 m); simx clamped the offset to 0 and the far end to its 1 mm cutoff."""
    no_gravity = W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, 0))))
    body = (no_gravity
            + W.cuboid_shape(1, -1, "Bulb", (0.02, 0.02, 0.02), (0.5, 0, 0.99), dynamic=False)
            + W.proximity_sensor(2, -1, "Success", kind=30, offset=-0.015, reach=0.01,
                                 sizes=(0.02, 0.02, 0.02, 0.02, 0.1, 0.2), pos=(0, 0, 1)))
    f = tmp_path / "holder.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=40700))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "holder")
    sim = Simulation(xml, realtime=False)
    try:
        assert sim.world.resolve("Success").settings.get("far") == "-0.005"
        api = client_context(sim).sim
        sensor, bulb = api.getObject("/Success"), api.getObject("/Bulb")
        assert api.checkProximitySensor(sensor, bulb)[0] == 0  # beside the volume
        api.setObjectPosition(bulb, -1, [0, 0, 0.98])  # top face 0.01 m below the origin: inside
        res, dist, point, hit, _ = api.readProximitySensor(sensor)
        assert (res, hit) == (1, bulb) and dist == pytest.approx(0.01, abs=1e-3)
        assert point[2] == pytest.approx(-0.01, abs=1e-3)
        api.setObjectPosition(bulb, -1, [0, 0, 1.005])  # straddling the origin: its bottom 5 mm below
        assert api.checkProximitySensor(sensor, bulb)[0] == 1
        api.setObjectPosition(bulb, -1, [0, 0, 1.02])  # above the origin: out of the volume
        assert api.checkProximitySensor(sensor, bulb)[0] == 0
    finally:
        sim.close()
