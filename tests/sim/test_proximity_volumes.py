"""V-REP's pyramid, cylinder and disc proximity volumes (``volume=`` in a sensor's ``simx:``
settings, what ``simx-convert`` writes from a ``.ttt`` file's sensors): the pyramid and the
cylinder exact on triangles (simx_server/sim/proximity_volume.py), the disc a set of rays filling
the volume (simx_server/sim/proximity.py ``volume_rays``); the reading is the detection nearest
to the sensor's origin, as V-REP's."""

from __future__ import annotations

import numpy as np
import pytest

from simx_wire.protocol import ArgumentError
from simx_server.scene.simulation import Simulation
from simx_server.sim import proximity

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCENE = """<mujoco model="volumes">
  <option gravity="0 0 0"/>
  <worldbody>
    <site name="Sensor" pos="0 0 0"/>
    <body name="Target" pos="{x} {y} {z}"><geom type="{kind}" size="{size}"/></body>
  </worldbody>
  <sensor><rangefinder site="Sensor" cutoff="{cutoff}"/></sensor>
  <custom><text name="simx:Sensor" data="{settings}"/></custom>
</mujoco>
"""


def read(tmp_path, settings: str, x: float, y: float = 0.0, z: float = 0.3, cutoff: float = 0.5):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE.format(x=x, y=y, z=z, cutoff=cutoff, settings=settings, kind="box", size="0.02 0.02 0.02"))
    sim = Simulation(path, realtime=False)
    try:
        return proximity.proximity_reading(sim, sim.world.resolve("Sensor").handle)
    finally:
        sim.close()


@pytest.mark.parametrize("settings, inside, outside", [
    # a box-shaped zone 0.4 m x 0.2 m wide (the kitchen's door sensors are such pyramids)
    ("volume=pyramid size=0.4,0.2 size_far=0.4,0.2", (0.15, 0.0), (0.3, 0.0)),
    ("volume=pyramid size=0.4,0.2 size_far=0.4,0.2", (0.0, 0.08), (0.0, 0.15)),
    # a frustum that widens: 0.05 m at the sensor, 0.6 m at 0.5 m (0.33 m across at z = 0.3)
    ("volume=pyramid size=0.05,0.05 size_far=0.6,0.6", (0.13, 0.0), (0.25, 0.0)),
    ("volume=cylinder radius=0.12", (0.0, -0.1), (0.0, -0.2)),
    # a flat 60-degree fan in the x-z plane: x = 0.15 at z = 0.3 is 26.6 degrees off the axis
    ("volume=disc angle=60", (0.15, 0.0), (0.0, 0.1)),
])
def test_a_volume_sees_what_lies_in_it_and_not_beside_it(tmp_path, settings, inside, outside):
    detected, point, handle, normal = read(tmp_path, settings, *inside)
    assert detected and handle >= 0
    assert point[2] == pytest.approx(0.28, abs=0.03)  # the target's near face (sensor frame)
    assert normal[2] < -0.5  # facing the sensor
    assert read(tmp_path, settings, *outside)[0] is False
    assert read(tmp_path, "volume=ray", *inside)[0] is False  # a ray along +z misses it


def test_the_volume_ends_at_its_range_and_starts_at_its_offset(tmp_path):
    pyramid = "volume=pyramid size=0.2,0.2"
    assert read(tmp_path, pyramid, 0.05, z=0.3, cutoff=0.25)[0] is False  # beyond the range
    assert read(tmp_path, pyramid + " offset=0.35", 0.05, z=0.3)[0] is False  # before the offset
    assert read(tmp_path, pyramid + " offset=0.1", 0.05, z=0.3)[0] is True


def test_bad_volume_settings_are_errors_naming_the_sensor(tmp_path):
    with pytest.raises(ArgumentError, match="'Sensor': volume='sphere'"):
        read(tmp_path, "volume=sphere", 0.0)
    with pytest.raises(ArgumentError, match="'Sensor': size='0.1'"):
        read(tmp_path, "volume=pyramid size=0.1", 0.0)


EXACT = """<mujoco model="exact">
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="floor"><geom type="plane" size="0 0 0.05"/></body>
    <site name="Sensor" pos="0 0 0" zaxis="0 -1 0"/>
    <body name="rod" pos="0.031 -0.25 0.02"><geom type="box" size="0.001 0.001 0.01"/></body>
  </worldbody>
  <sensor><rangefinder site="Sensor" cutoff="0.3"/></sensor>
  <custom><text name="simx:Sensor" data="volume=pyramid offset=0.1 size=0.2,0.1 size_far=0.4,0.2"/></custom>
</mujoco>
"""


def test_pyramid_finds_the_nearest_point_inside_exactly(tmp_path):
    """PyRep's test scene: a floor through the pyramid's near face is detected at the face's
    centre (CoppeliaSim reports 0.1, the offset); with the floor not detectable, a 2 mm rod
    between the former ray grid's lines is found at its nearest corner."""
    path = tmp_path / "scene.xml"
    path.write_text(EXACT)
    sim = Simulation(path, realtime=False)
    try:
        sensor = sim.world.resolve("Sensor").handle
        detected, point, handle, normal = proximity.proximity_reading(sim, sensor)
        assert detected and handle == sim.world.resolve("floor").handle
        assert point == pytest.approx([0.0, 0.0, 0.1], abs=1e-9)
        rod = sim.world.resolve("rod").handle
        detected, point, handle, normal = proximity.proximity_reading(sim, sensor, entity=rod)
        assert detected and handle == rod
        assert point == pytest.approx([0.03, 0.01, 0.249], abs=1e-9)  # its corner nearest the sensor
        assert normal[2] == pytest.approx(-1.0)  # its face towards the sensor
    finally:
        sim.close()


BAR = """<mujoco model="bar">
  <option gravity="0 0 0"/>
  <worldbody>
    <site name="Sensor" pos="0 0 0" zaxis="1 0 0"/>
    <body name="bar" pos="0.1 0 {z}"><geom type="box" size="0.27 0.014 0.014"/></body>
  </worldbody>
  <sensor><rangefinder site="Sensor" cutoff="0.2"/></sensor>
  <custom><text name="simx:Sensor" data="volume=cylinder radius=0.02 radius_far=0.02 faces={faces}"/></custom>
</mujoco>
"""


@pytest.mark.parametrize("z, faces, seen", [(-0.021, 32, True), (-0.021, 4, True), (-0.031, 32, True),
                                             (-0.031, 4, False), (-0.04, 32, False)])
def test_cylinder_sees_a_bar_along_its_axis_that_its_rays_start_inside(tmp_path, z, faces, seen):
    """RLBench's open_oven: the open door's handle, a bar 0.54 m long, lies along the success
    sensor's cylinder (radius 0.02 m, range 0.2 m) 7 mm below its axis and beyond both its ends.
    CoppeliaSim sees its top face in the volume (a prism of ``faceNumber`` sides inscribed in the
    circle, CConvexVolume); rays along the axis start inside the bar and saw nothing. A face
    17 mm below the axis lies inside 32 sides (apothem 19.95 mm), outside 4 (14.1 mm)."""
    path = tmp_path / "scene.xml"
    path.write_text(BAR.format(z=z, faces=faces))
    sim = Simulation(path, realtime=False)
    try:
        detected, point, handle, normal = proximity.proximity_reading(sim, sim.world.resolve("Sensor").handle)
        assert detected is seen
        if seen:
            assert handle == sim.world.resolve("bar").handle
            # on the near cap, the face's distance below the axis along the sensor's x (world -z)
            assert point == pytest.approx([-(z + 0.014), 0.0, 0.0], abs=1e-9)
    finally:
        sim.close()


LONG = """<mujoco model="long">
  <option gravity="0 0 0"/>
  <worldbody>
    <site name="Sensor" pos="0 0 0"/>
    <body name="Bar"><geom type="capsule" fromto="{x0} 0 0.3 1.2 0 0.3" size="0.01"/></body>
    <body name="Far" pos="0 0 2"><geom type="sphere" size="0.05"/></body>
  </worldbody>
  <sensor><rangefinder site="Sensor" cutoff="0.5"/></sensor>
  <custom><text name="simx:Sensor" data="{settings}"/></custom>
</mujoco>
"""


@pytest.mark.parametrize("settings, x0", [
    ("volume=pyramid size=0.2,0.2", 0.02), ("volume=disc angle=60", 0.1), ("volume=ray", -0.005),
    ("angle=30", 0.02),
])
def test_a_shape_looked_for_alone_is_seen_where_it_reaches_in_from_far(tmp_path, settings, x0):
    # The bar's centre lies 0.6 m off the sensor's axis, well outside the sphere round the
    # volume; only its end reaches in. The quick test that skips casting for shapes out of
    # reach must bound each shape by its whole extent, not its centre.
    path = tmp_path / "scene.xml"
    path.write_text(LONG.format(x0=x0, settings=settings))
    sim = Simulation(path, realtime=False)
    try:
        sensor = sim.world.resolve("Sensor").handle
        bar, far = sim.world.resolve("Bar").handle, sim.world.resolve("Far").handle
        detected, point, handle, _ = proximity.proximity_reading(sim, sensor, bar)
        assert detected and handle == bar and point[2] == pytest.approx(0.29, abs=0.02)
        assert proximity.proximity_reading(sim, sensor, far)[0] is False  # beyond the range
        assert proximity.proximity_reading(sim, sensor)[0] is True
    finally:
        sim.close()


@pytest.mark.parametrize("kind, size", [("sphere", "0.0025"), ("ellipsoid", "0.002 0.0025 0.003"),
                                        ("capsule", "0.002 0.001"), ("cylinder", "0.0025 0.002")])
def test_a_small_primitive_between_the_volume_rays_is_seen(tmp_path, kind, size):
    """RLBench's pour_from_cup_to_cup: its success sensor, a cylinder 5 cm across, looks for
    twenty drops, spheres 5 mm across, at the bottom of the target cup; CoppeliaSim meshes its
    pure shapes and sees every one. Here the drop lies 5 mm from the nearest of the rays that
    would fill the volume: it is found on its tessellation."""
    path = tmp_path / "scene.xml"
    path.write_text(SCENE.format(x=0.009, y=0.009, z=0.015, cutoff=0.03, settings="volume=cylinder radius=0.025 faces=8",
                                 kind=kind, size=size))
    sim = Simulation(path, realtime=False)
    try:
        sensor, drop = sim.world.resolve("Sensor").handle, sim.world.resolve("Target").handle
        for entity in (None, drop):
            detected, point, handle, normal = proximity.proximity_reading(sim, sensor, entity)
            assert detected and handle == drop
            assert 0.012 < float(np.linalg.norm(point)) < 0.0195  # on the near side of the drop
        if kind == "sphere":  # the centre's distance less the radius, give or take the facets
            assert float(np.linalg.norm(point)) == pytest.approx(float(np.linalg.norm([0.009, 0.009, 0.015])) - 0.0025,
                                                                 abs=2e-5)
    finally:
        sim.close()
