"""Cone-type proximity sensors (V-REP's sonars, ``angle=``/``max_angle=`` in a sensor's simx:
settings) and the bundled Pioneer P3-DX scene's sensors and collision objects, in process."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ROOT

from simx_client.protocol import ArgumentError
from simx_server.scene.simulation import Simulation
from simx_server.sim.collisions import collision, probes
from simx_server.sim.proximity import cone_directions, proximity_reading

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

PIONEER = ROOT / "scenes" / "pioneer_p3dx.xml"

# Two sensors at the origin looking along +x (site +z = world +x), one a ray, one a 30-degree
# cone hearing surfaces met within 70 degrees of their normal; a box 1 m ahead and 0.2 m to
# the side (11 degrees off the axis: inside the cone, beside the ray); the floor 0.2 m below.
SCENE = """<mujoco>
  <worldbody>
    <body name="Floor"><geom type="plane" size="5 5 0.1" pos="0 0 -0.2"/></body>
    <body name="Box" pos="1.05 0.2 0"><geom type="box" size="0.05 0.05 0.05"/></body>
    <body name="Mount">
      <site name="ray" zaxis="1 0 0"/>
      <site name="cone" zaxis="1 0 0"/>
      <site name="cone_all" zaxis="1 0 0"/>
    </body>
  </worldbody>
  <sensor>
    <rangefinder site="ray" cutoff="2"/>
    <rangefinder site="cone" cutoff="2"/>
    <rangefinder site="cone_all" cutoff="2"/>
  </sensor>
  <custom>
    <text name="simx:cone" data="angle=30 max_angle=70"/>
    <text name="simx:cone_all" data="angle=30"/>
  </custom>
</mujoco>"""


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "cone.xml"
    path.write_text(SCENE)
    s = Simulation(path, realtime=False)
    yield s
    s.close()


def handle(sim, name: str) -> int:
    return next(o.handle for o in sim.world.objects.values() if o.name == name)


def test_cone_directions_fill_the_cone():
    dirs = cone_directions(math.radians(30))
    assert np.allclose(np.linalg.norm(dirs, axis=1), 1)
    off_axis = np.degrees(np.arccos(np.clip(dirs[:, 2], -1, 1)))
    assert off_axis.max() == pytest.approx(15) and off_axis.min() == 0
    # no gap wider than a ring step between the axis and the edge, all the way round
    assert np.all(np.diff(np.unique(np.round(off_axis, 6))) <= 3.75 + 1e-9)


def test_a_cone_hears_what_lies_beside_its_axis_and_a_ray_does_not(sim):
    assert proximity_reading(sim, handle(sim, "ray"))[0] is False  # the floor and the box miss the axis
    detected, point, obj, normal = proximity_reading(sim, handle(sim, "cone"))
    assert detected and obj == handle(sim, "Box")
    # the box's face at x = 1.0, in the sensor frame (z along the view): about 1 m ahead
    assert 0.99 < np.linalg.norm(point) < 1.03 and point[2] > 0.97
    assert normal[2] < -0.9  # the face looks back at the sensor


def test_max_angle_leaves_out_grazing_surfaces(sim):
    # without max_angle the cone hears the floor where its lowest rays meet it (0.2 / sin 15 deg = 0.77 m, nearer than the box)
    detected, point, obj, _ = proximity_reading(sim, handle(sim, "cone_all"))
    assert detected and obj == handle(sim, "Floor")
    assert np.linalg.norm(point) == pytest.approx(0.2 / math.sin(math.radians(15)), rel=0.02)
    assert proximity_reading(sim, handle(sim, "cone"))[2] == handle(sim, "Box")


@pytest.mark.parametrize("data", ["angle=abc", "angle=0", "angle=180", "angle=30 max_angle=95"])
def test_bad_cone_settings_are_argument_errors_naming_the_sensor(tmp_path, data):
    path = tmp_path / "bad.xml"
    path.write_text(SCENE.replace('data="angle=30 max_angle=70"', f'data="{data}"'))
    s = Simulation(path, realtime=False)
    try:
        with pytest.raises(ArgumentError, match="proximity sensor 'cone'"):
            proximity_reading(s, handle(s, "cone"))
        assert proximity_reading(s, handle(s, "ray"))[0] is False  # the others still read
    finally:
        s.close()


def test_pioneer_scene_has_v_reps_names_sonars_and_collision_objects():
    s = Simulation(PIONEER, realtime=False)
    try:
        world = s.world
        names = {o.name for o in world.objects.values()}
        assert {"Pioneer_p3dx", "Pioneer_p3dx_leftMotor", "Pioneer_p3dx_rightMotor", "Room"} <= names
        sonars = [handle(s, f"Pioneer_p3dx_ultrasonicSensor{i}") for i in range(1, 17)]
        # V-REP's layout: 1 looks left, 4 and 5 ahead (+-10 deg), 8 right, 12 and 13 back
        look = {i + 1: world.frame(h)[1][:, 2] for i, h in enumerate(sonars)}
        heading = {i: math.degrees(math.atan2(v[1], v[0])) for i, v in look.items()}
        assert heading[1] == pytest.approx(90, abs=0.1) and heading[8] == pytest.approx(-90, abs=0.1)
        assert heading[4] == pytest.approx(10, abs=0.1) and heading[5] == pytest.approx(-10, abs=0.1)
        assert abs(heading[12]) == pytest.approx(170, abs=0.1) and abs(heading[13]) == pytest.approx(170, abs=0.1)
        # at the start (room centre, facing +x) the front sonars hear an obstacle, not the floor
        heard = {proximity_reading(s, h)[2] for h in sonars} - {-1}
        assert heard == {handle(s, "Room")}
        # a collision object reports the robot against the room only when it touches it
        robot, room = handle(s, "Pioneer_p3dx"), handle(s, "Room")
        assert {"Pioneer_room", "leftWheel_room", "rightWheel_room"} <= set(probes(s, "collision"))
        assert not collision(s, robot, room)
        world.set_pose(robot, -1, [2.31, 0, 0.0975])  # the top deck 1 cm into the east wall (x = 2.5)
        assert collision(s, robot, room)
    finally:
        s.close()
