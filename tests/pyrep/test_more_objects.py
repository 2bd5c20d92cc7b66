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


def test_an_old_path_is_read_as_pyrep_reads_it(pr):
    """A CoppeliaSim 4.1 path (V-REP's old path object, as RLBench's task models hold them):
    poses along it are ``simGetPositionOnPath`` / ``simGetOrientationOnPath`` on its curve, and
    control points go in as PyRep's add-on inserts them."""
    from pyrep.backend import sim
    path = CartesianPath(int(sim.call("createPath", -1)))
    path.set_position([0.0, 0.0, 0.5])
    path.insert_control_points([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0, 0.0, 0.5]])
    for t in (0.0, 0.3, 1.0):
        pos, ori = path.get_pose_on_path(t)
        assert np.allclose(pos, sim.call("getPositionOnPath", path.get_handle(), t))
        assert np.allclose(ori, sim.call("getOrientationOnPath", path.get_handle(), t))
    assert np.allclose(path.get_pose_on_path(0.0)[0], [0.0, 0.0, 0.5], atol=1e-6)
    assert np.allclose(path.get_pose_on_path(1.0)[0], [1.0, 0.0, 0.5], atol=1e-6)


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



def _ring(n: int = 24, radius: float = 0.2, tube: float = 0.04) -> tuple[str, str]:
    """A torus mesh (``n`` x 8 quads): MJCF vertex and face texts."""
    u = np.linspace(0, 2 * np.pi, n, endpoint=False)
    v = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    verts = [((radius + tube * np.cos(b)) * np.cos(a), (radius + tube * np.cos(b)) * np.sin(a), tube * np.sin(b))
             for a in u for b in v]
    faces = []
    for i in range(n):
        for j in range(8):
            p, q, p2, q2 = i * 8 + j, (i + 1) % n * 8 + j, i * 8 + (j + 1) % 8, (i + 1) % n * 8 + (j + 1) % 8
            faces += [(p, q, q2), (p, q2, p2)]
    return ("  ".join(f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts),
            "  ".join(f"{a} {b} {c}" for a, b, c in faces))


def test_octree_takes_a_visual_only_mesh(tmp_path):
    """A mesh that collides with nothing (and whose inertia is not its hull's) gets no convex
    hull from MuJoCo, so no distance field to sample: ``insert_object`` samples its triangles
    instead, and the voxels of a ring lie on its tube, none in its hole (PyRep's octree tests
    insert the Panda's visual link so)."""
    from pyrep import PyRep

    vertex, face = _ring()
    scene = tmp_path / "visual_mesh.xml"
    scene.write_text(f"""<mujoco><asset><mesh name="ring" inertia="shell" vertex="{vertex}" face="{face}"/></asset>
<worldbody><body name="deco" pos="0 0 0.5">
  <geom name="deco" type="mesh" mesh="ring" contype="0" conaffinity="0"/>
</body></worldbody></mujoco>""")
    pr = PyRep()
    pr.launch(str(scene), headless=True)
    try:
        octree = Octree.create(0.02)
        octree.insert_object(Shape("deco"))
        voxels = np.asarray(octree.get_voxels()).reshape(-1, 3)
        off_tube = np.hypot(np.linalg.norm(voxels[:, :2], axis=1) - 0.2, voxels[:, 2] - 0.5)
        assert len(voxels) > 50
        assert off_tube.max() <= 0.04 + 0.02, off_tube.max()  # on the tube, within a voxel
        angles = np.degrees(np.arctan2(voxels[:, 1], voxels[:, 0])) % 360
        assert np.histogram(angles, bins=8, range=(0, 360))[0].min() > 0  # all around the ring
    finally:
        pr.shutdown()
