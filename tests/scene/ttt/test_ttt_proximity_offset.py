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
