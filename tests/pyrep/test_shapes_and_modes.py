"""``pyrep``'s shape and joint methods that the API table gained for PyRep (issue 51): dynamic and
respondable switches, joint modes and the motor lock, one-triangle meshes, decimation, convex
decomposition, applied textures and re-oriented bounding boxes, on the small scene."""

from __future__ import annotations

import numpy as np
import pytest

from pyrep.const import JointMode
from pyrep.objects import Joint, Shape


def test_cube_switched_static_hangs_and_unresponsive_falls_through(pr):
    cube = Shape("cube")
    assert cube.is_dynamic() and cube.is_respondable()
    cube.set_dynamic(False)
    assert not cube.is_dynamic()
    for _ in range(10):
        pr.step()
    assert cube.get_position()[2] == pytest.approx(0.3)  # static where it was
    cube.set_dynamic(True)
    cube.set_respondable(False)
    assert cube.is_dynamic() and not cube.is_respondable()
    for _ in range(30):
        pr.step()
    assert cube.get_position()[2] < 0.0  # through the floor


def test_joint_in_ik_mode_is_placed_and_stays(pr):
    hinge, link = Joint("hinge"), Shape("link")
    assert hinge.get_joint_mode() == JointMode.FORCE
    hinge.set_joint_mode(JointMode.IK)
    assert hinge.get_joint_mode() == JointMode.IK
    hinge.set_joint_position(0.5)
    hinge.set_joint_target_position(1.0)  # its motor gives no force in IK mode
    for _ in range(10):
        pr.step()
    assert hinge.get_joint_position() == pytest.approx(0.5, abs=1e-12)
    assert link.get_orientation()[2] == pytest.approx(0.5, abs=1e-9)
    hinge.set_joint_mode(JointMode.FORCE)
    for _ in range(10):
        pr.step()
    assert hinge.get_joint_position() > 0.6  # the motor drives it again
    assert not hinge.is_motor_locked_at_zero_velocity()
    hinge.set_motor_locked_at_zero_velocity(True)
    assert hinge.is_motor_locked_at_zero_velocity()


def test_meshes_made_decimated_decomposed_and_textured(pr):
    triangle = Shape.create_mesh([-0.1, -0.1, 0.0, -0.1, 0.1, 0.0, 0.1, 0.0, 0.0], [0, 1, 2])
    assert isinstance(triangle, Shape)
    k = 15
    x, y = np.meshgrid(np.linspace(0, 0.3, k), np.linspace(0, 0.3, k))
    vertices = np.column_stack([x.ravel(), y.ravel(), 0.05 * (x.ravel() - 0.15) ** 2 * 40])  # a trough
    faces = [[i * k + j, i * k + j + 1, (i + 1) * k + j + 1] for i in range(k - 1) for j in range(k - 1)]
    faces += [[i * k + j, (i + 1) * k + j + 1, (i + 1) * k + j] for i in range(k - 1) for j in range(k - 1)]
    trough = Shape.create_mesh(vertices.ravel().tolist(), np.ravel(faces).tolist())
    trough.set_position([0.0, 0.8, 0.5])
    _, indices, _ = trough.get_mesh_data()
    fewer = trough.decimate_mesh(0.2)
    assert len(fewer.get_mesh_data()[1]) < 0.3 * len(indices)
    assert np.allclose(fewer.get_position(), trough.get_position())
    with pytest.raises(ValueError):
        trough.decimate_mesh(0.95)
    hulls = trough.get_convex_decomposition(use_vhacd=True, vhacd_res=10000)
    assert isinstance(hulls, Shape) and hulls != trough
    assert trough.get_convex_decomposition(morph=True, same=True) == trough
    _, indices, _ = triangle.get_mesh_data()
    coords = np.tile([[0.0, 0.0], [1.0, 0.0], [0.5, 1.0]], (len(indices), 1))
    image = np.zeros((2, 2, 3), np.uint8)
    image[0, 0] = [255, 0, 0]
    triangle.apply_texture(coords, image)
    info = triangle.get_shape_viz(0)
    assert info.texture.shape == (2, 2, 4) and tuple(info.texture[0, 0]) == (255, 0, 0, 255)
    assert np.allclose(info.texture_coords, coords)
    with pytest.raises(TypeError):
        triangle.apply_texture(coords, image.tolist())


def test_reorient_bounding_box_turns_the_frame_not_the_mesh(pr):
    box = Shape.create_mesh([0, 0, 0, 0.4, 0, 0, 0, 0.1, 0, 0.4, 0.1, 0, 0, 0, 0.05, 0.4, 0, 0.05, 0, 0.1, 0.05,
                             0.4, 0.1, 0.05],
                            [0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6,
                             1, 3, 5, 3, 7, 5])
    # its frame: x along the 0.05 m side, z along the 0.4 m one (a new mesh's main axes); lay the
    # long side level, turned 0.7 rad about the world's z
    c, s = np.cos(0.7), np.sin(0.7)
    turned = np.eye(4)
    turned[:3, :3] = np.column_stack([[0.0, 0.0, 1.0], [s, -c, 0.0], [c, s, 0.0]])
    box.set_matrix(turned)

    def size():
        bb = np.array(box.get_bounding_box())
        return bb[1::2] - bb[::2]

    before = size()
    box.reorient_bounding_box()  # along the world's axes: a box turned by 0.7 rad needs a bigger one
    assert np.allclose(box.get_orientation(), 0.0, atol=1e-9)
    assert size() == pytest.approx([0.4 * np.cos(0.7) + 0.1 * np.sin(0.7), 0.4 * np.sin(0.7) + 0.1 * np.cos(0.7),
                                    0.05], abs=1e-6)
    assert np.prod(size()) > np.prod(before)
    box.reorient_bounding_box(relative_to=box)  # its own smallest box again
    assert sorted(size()) == pytest.approx([0.05, 0.1, 0.4], abs=1e-6)



_TET = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def test_meshes_of_the_programs_own_folders_import(pr, tmp_path_factory):
    """A PyRep program owns its process: ``Shape.import_mesh`` / ``import_shape`` read its files
    wherever they are (RLBench imports its procedural objects from its package folder), as
    ``PyRep.import_model`` does; a server's own trust rules are for remote clients."""
    obj = tmp_path_factory.mktemp("elsewhere") / "tet.obj"
    obj.write_text(_TET)
    assert Shape.import_mesh(str(obj)).get_handle() != Shape.import_shape(str(obj)).get_handle()


def test_a_new_mesh_frame_lies_along_its_main_axes_at_its_box_centre(pr):
    """CoppeliaSim puts a new mesh shape's frame along the mesh's main axes, x the smallest
    extent and z the largest, at the centre of its box (``CShape::_acceptNewGeometry``): RLBench
    picks its procedural objects at their frame. A 0.3 x 0.2 x 0.1 m box turned 0.5 rad about z,
    its corner at (0.4, 0.1, 0.2): the frame sits at its centre, its z along the long side."""
    c, s = np.cos(0.5), np.sin(0.5)
    corners = np.array([[x, y, z] for x in (0, 0.3) for y in (0, 0.2) for z in (0, 0.1)])
    world = corners @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + [0.4, 0.1, 0.2]
    faces = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3]
    box = Shape.create_mesh(world.reshape(-1).tolist(), faces)
    assert np.allclose(box.get_position(), world.mean(axis=0), atol=1e-6)
    assert np.allclose(box.get_bounding_box(), [-0.05, 0.05, -0.1, 0.1, -0.15, 0.15], atol=1e-6)
    z_axis = box.get_matrix()[:3, 2]
    assert abs(float(z_axis @ [c, s, 0])) == pytest.approx(1.0, abs=1e-6)  # the 0.3 m side
    vertices, _, _ = box.get_mesh_data()  # in the shape's frame, the same box
    m = box.get_matrix()
    back = np.asarray(vertices) @ m[:3, :3].T + m[:3, 3]
    assert np.sort(back, axis=0) == pytest.approx(np.sort(world, axis=0), abs=1e-6)


def test_a_new_mesh_is_static_and_a_procedural_object_falls_whole(pr, tmp_path):
    """CoppeliaSim's new mesh shape is static and not respondable (coppeliaSimLib 4.1 ``CShape``);
    RLBench's ``sample_procedural_objects`` hangs the visual mesh from the collision mesh, keeps
    it static, then makes the collision mesh dynamic: the two fall together."""
    obj = tmp_path / "tet.obj"
    obj.write_text(_TET)
    resp, vis = Shape.import_mesh(str(obj)), Shape.import_mesh(str(obj))
    assert not resp.is_dynamic() and not resp.is_respondable()
    resp.set_position([0.0, 0.5, 0.15])
    vis.set_position([0.0, 0.5, 0.15])
    vis.set_parent(resp)
    vis.set_dynamic(False)
    vis.set_respondable(False)
    resp.set_dynamic(True)
    resp.set_respondable(True)
    resp.set_parent(Shape("base"))  # a static parent: it stays free
    for _ in range(30):
        pr.step()
    vertices, _, _ = resp.get_mesh_data()
    m = resp.get_matrix()
    lowest = float((np.asarray(vertices) @ m[:3, :3].T + m[:3, 3])[:, 2].min())
    assert lowest == pytest.approx(0.0, abs=0.01)  # on the floor
    assert np.allclose(vis.get_position(), resp.get_position(), atol=1e-6)  # carried with it
