"""Placing joints and the shapes that hang from them (``simSetObjectPosition`` & co. on a joint,
as V-REP's omni-wheel scripts do every step): the joint moves with what hangs from it, a shape
moves relative to its joint, joint states are kept, and a stop puts the scene back."""

from __future__ import annotations

import numpy as np
import pytest

from simx_server.sim.world import World
from simx_wire.protocol import ObjectTypeError

SCENE = """<mujoco>
  <worldbody>
    <body name="base" pos="0 0 0.5">
      <geom type="box" size="0.1 0.1 0.1"/>
      <body name="link" pos="0.3 0 0">
        <joint name="hinge" type="hinge" axis="0 0 1" pos="-0.1 0 0"/>
        <geom type="box" size="0.1 0.02 0.02" mass="0.5"/>
        <body name="slider_body" pos="0.2 0 0">
          <joint name="slider" type="slide" axis="1 0 0"/>
          <geom type="sphere" size="0.03" mass="0.1"/>
        </body>
      </body>
      <body name="ball_body" pos="0 0.3 0">
        <joint name="ball" type="ball"/>
        <geom type="sphere" size="0.03" mass="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture()
def world(tmp_path):
    f = tmp_path / "joints.xml"
    f.write_text(SCENE)
    w = World(f, 0.05)
    w.set_joint_position(w.resolve("hinge").handle, 0.4)
    w.set_joint_position(w.resolve("slider").handle, 0.05)
    return w


def _h(world, name):
    return world.resolve(name).handle


def test_a_joint_moves_with_what_hangs_from_it(world):
    hinge, link = _h(world, "hinge"), _h(world, "link")
    body_in_joint = world.relative_frame(link, hinge)
    world.set_pose(hinge, -1, position=[1.0, 2.0, 0.3])
    assert world.position(hinge, -1) == pytest.approx([1.0, 2.0, 0.3], abs=1e-9)
    assert world.joint_position(hinge) == pytest.approx(0.4)  # its state is kept
    after = world.relative_frame(link, hinge)  # the link moved rigidly with it
    np.testing.assert_allclose(after[0], body_in_joint[0], atol=1e-9)
    np.testing.assert_allclose(after[1], body_in_joint[1], atol=1e-9)
    # turned: the joint's axis (its frame's z) as asked, relative to the base
    world.set_pose(hinge, _h(world, "base"), rotation=np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]))
    _, r = world.relative_frame(hinge, _h(world, "base"))
    np.testing.assert_allclose(r[:, 2], [0, -1, 0], atol=1e-9)
    assert world.position(hinge, -1) == pytest.approx([1.0, 2.0, 0.3], abs=1e-9)


def test_a_shape_moves_relative_to_its_joint_which_stays(world):
    slider, body = _h(world, "slider"), _h(world, "slider_body")
    anchor, axis = world.data.xanchor[world.resolve("slider").mj_id].copy(), world.data.xaxis[world.resolve("slider").mj_id].copy()
    target = np.array([0.1, 0.05, 0.0])
    world.set_pose(body, _h(world, "link"), position=target)
    assert world.position(body, _h(world, "link")) == pytest.approx(target, abs=1e-9)
    j = world.resolve("slider").mj_id
    np.testing.assert_allclose(world.data.xanchor[j], anchor, atol=1e-9)
    np.testing.assert_allclose(world.data.xaxis[j], axis, atol=1e-9)
    assert world.joint_position(slider) == pytest.approx(0.05)


def test_a_ball_joint_is_refused_and_a_reset_puts_everything_back(world):
    with pytest.raises(ObjectTypeError, match="'ball' is a joint: it cannot be placed"):
        world.set_pose(_h(world, "ball"), -1, position=[0, 0, 1])
    with pytest.raises(ObjectTypeError, match="'ball_body' is moved by its joints"):
        world.set_pose(_h(world, "ball_body"), -1, position=[0, 0, 1])
    body_pos, jnt_pos = world.model.body_pos.copy(), world.model.jnt_pos.copy()
    world.reset()
    before = (world.model.body_pos.copy(), world.model.jnt_pos.copy())
    world.set_pose(_h(world, "hinge"), -1, position=[1.0, 2.0, 0.3])
    world.set_pose(_h(world, "slider_body"), -1, position=[0.0, 0.0, 2.0])
    assert not np.allclose(world.model.body_pos, before[0])
    world.reset()
    np.testing.assert_allclose(world.model.body_pos, before[0])
    np.testing.assert_allclose(world.model.jnt_pos, before[1])
    np.testing.assert_allclose(body_pos, before[0])
    np.testing.assert_allclose(jnt_pos, before[1])


def test_a_shape_on_a_hinge_turns_relative_to_it(world):
    hinge, link, base = _h(world, "hinge"), _h(world, "link"), _h(world, "base")
    j = world.resolve("hinge").mj_id
    anchor, axis = world.data.xanchor[j].copy(), world.data.xaxis[j].copy()
    c, s = np.cos(0.3), np.sin(0.3)
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    world.set_pose(link, base, position=[0.25, 0.1, 0.0], rotation=turn)
    p, r = world.relative_frame(link, base)
    np.testing.assert_allclose(p, [0.25, 0.1, 0.0], atol=1e-9)
    np.testing.assert_allclose(r, turn, atol=1e-9)
    np.testing.assert_allclose(world.data.xanchor[j], anchor, atol=1e-9)
    np.testing.assert_allclose(world.data.xaxis[j], axis, atol=1e-9)
    assert world.joint_position(hinge) == pytest.approx(0.4)
