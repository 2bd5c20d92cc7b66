"""``pyrep``'s sensors, lights, octrees, paths, signals and created objects on the small scene."""

from __future__ import annotations

import numpy as np
import pytest

from pyrep.errors import PyRepError
from pyrep.misc.signals import FloatSignal, IntegerSignal, StringSignal
from pyrep.objects import CartesianPath, Dummy, ForceSensor, Light, Octree, ProximitySensor, Shape


def test_proximity_sensor_reads_the_cube_below(pr):
    sensor, cube = ProximitySensor("prox"), Shape("cube")
    pr.step()
    top = cube.get_position()[2] + 0.05
    assert sensor.read() == pytest.approx(1.0 - top, abs=0.01)
    assert sensor.is_detected(cube)
    assert not sensor.is_detected(Shape("base"))


def test_force_sensor_created_reads_vectors(pr):
    sensor = ForceSensor.create(0.02)
    force, torque = sensor.read()
    assert len(force) == 3 and len(torque) == 3
    sensor.remove()
    assert not sensor.still_exists()


def test_light_switches_and_colours(pr):
    light = Light("light")
    light.turn_off()
    assert light.is_off()
    light.turn_on()
    assert light.is_on()
    light.set_diffuse([0.2, 0.5, 0.9])
    assert np.allclose(light.get_diffuse(), [0.2, 0.5, 0.9])
    light.set_intensity_properties(cast_shadows=True, spot_cutoff=0.4)
    shadows, _, cutoff, *_ = light.get_intensity_properties()
    assert shadows is True and cutoff == 0.4
    with pytest.raises(Exception, match="attenuation"):
        light.set_intensity_properties(const_atten_factor=1.0)


def test_octree_voxels(pr):
    octree = Octree.create(0.05)
    octree.insert_voxels([0.0, 0.0, 1.0])
    assert 1 <= len(octree.get_voxels()) // 3 <= 8
    assert octree.check_point_occupancy([0.0, 0.0, 1.0])
    octree.insert_object(Shape("cube"))
    assert len(octree.get_voxels()) // 3 > 1
    octree.clear_voxels()
    assert octree.get_voxels() == []
    with pytest.raises(ValueError):
        octree.insert_voxels([0.0, 0.0])


def test_cartesian_path_interpolates_control_points(pr):
    path = CartesianPath.create()
    path.insert_control_points([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0, 0.0, 0.5]])
    pos, ori = path.get_pose_on_path(0.5)
    assert np.allclose(pos, [0.5, 0.0, 0.0], atol=1e-6)
    assert np.allclose(ori, [0.0, 0.0, 0.25], atol=1e-6)


def test_signals_and_dummy_creation(pr):
    for cls, value in ((IntegerSignal, 7), (FloatSignal, 2.5), (StringSignal, "hello")):
        signal = cls("s")
        signal.set(value)
        assert signal.get() == pytest.approx(value) if isinstance(value, float) else signal.get() == value
        assert signal.clear() == 1
        with pytest.raises(PyRepError):
            signal.get()
    dummy = Dummy.create(0.02)
    dummy.set_position([0.1, 0.2, 0.3])
    assert np.allclose(dummy.get_position(), [0.1, 0.2, 0.3])
    assert dummy.check_distance(Shape("cube")) == pytest.approx(np.linalg.norm([0.35, 0.2, 0.0]) - 0.05, abs=0.06)


def test_octree_takes_a_visual_only_mesh(tmp_path):
    """A mesh that collides with nothing gets no convex hull from MuJoCo (no distance field):
    ``insert_object`` samples its triangles instead, so its voxels lie on its faces."""
    from pyrep import PyRep

    scene = tmp_path / "visual_mesh.xml"
    scene.write_text("""<mujoco><asset>
  <mesh name="tetra" vertex="0 0 0  0.2 0 0  0 0.2 0  0 0 0.2"/>
</asset><worldbody>
  <body name="deco" pos="0 0 0.5"><geom name="deco" type="mesh" mesh="tetra" contype="0" conaffinity="0"/></body>
</worldbody></mujoco>""")
    pr = PyRep()
    pr.launch(str(scene), headless=True)
    try:
        octree = Octree.create(0.02)
        octree.insert_object(Shape("deco"))
        voxels = np.asarray(octree.get_voxels()).reshape(-1, 3)
        assert len(voxels) > 10
        assert voxels.min(axis=0) == pytest.approx([0.0, 0.0, 0.5], abs=0.03)
        assert voxels.max(axis=0) == pytest.approx([0.2, 0.2, 0.7], abs=0.03)
    finally:
        pr.shutdown()
