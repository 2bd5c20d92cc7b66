"""The batched IK of simIK.findConfig's random search (simx_server.sim.ik_batch) against MuJoCo:
its forward kinematics and Jacobian as ``mj_kinematics`` / ``mj_jacSite`` give them, its rotation
vectors as ``mju_subQuat``'s, and its solutions reaching the target in MuJoCo's own kinematics."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from simx_server.sim import ik_batch

# a chain of five hinges at odd angles and one slide between them, and a tip site
XML = """
<mujoco>
  <worldbody>
    <body name="base" pos="0.1 -0.2 0.3" euler="10 20 30">
      <joint name="j1" type="hinge" axis="0 0 1" range="-3 3"/>
      <geom size="0.02"/>
      <body name="l1" pos="0 0.05 0.3" euler="0 40 0">
        <joint name="j2" type="hinge" axis="0 1 0" pos="0 0 -0.05" range="-2 2"/>
        <geom size="0.02"/>
        <body name="l2" pos="0.3 0 0" euler="15 0 -20">
          <joint name="j3" type="slide" axis="1 0 0" range="-0.1 0.2"/>
          <geom size="0.02"/>
          <body name="l3" pos="0.2 0.02 0">
            <joint name="j4" type="hinge" axis="0 1 1" range="-2.5 2.5"/>
            <geom size="0.02"/>
            <body name="l4" pos="0.1 0 0.05" euler="0 0 70">
              <joint name="j5" type="hinge" axis="1 0 0" range="-3 3"/>
              <geom size="0.02"/>
              <body name="l5" pos="0.05 0 0">
                <joint name="j6" type="hinge" axis="0 0 1" pos="0.01 0.02 0" range="-3 3"/>
                <geom size="0.02"/>
                <site name="tip" pos="0.08 0.01 -0.02" euler="30 10 5"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def rig():
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    data.qpos[:] = rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1]) * 0.5
    mujoco.mj_kinematics(model, data)
    tip = model.site("tip").id
    reached = mujoco.MjData(model)  # the target: where the tip is in another configuration
    reached.qpos[:] = rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1]) * 0.8
    mujoco.mj_kinematics(model, reached)
    target = (reached.site_xpos[tip].copy(), reached.site_xmat[tip].reshape(3, 3).copy())
    chain = ik_batch.Chain.build(model, data, list(range(model.njnt)),
                                 (data.site_xpos[tip].copy(), data.site_xmat[tip].reshape(3, 3).copy()),
                                 int(model.site_bodyid[tip]), target, -1, np.eye(3), 31, (1.0, 1.0), (1e-4, 1e-3))
    assert chain is not None
    return model, data, chain, tip, target


def test_forward_kinematics_and_jacobian_are_mujocos(rig):
    model, data, chain, tip, _ = rig
    rng = np.random.default_rng(1)
    q = rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1], (5, model.njnt))
    p, r, _, _ = chain.kinematics(q)
    e, jac, _ = chain.errors(q)
    d = mujoco.MjData(model)
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for k in range(len(q)):
        d.qpos[:] = q[k]
        mujoco.mj_kinematics(model, d)
        mujoco.mj_comPos(model, d)
        assert p[k] == pytest.approx(d.site_xpos[tip], abs=1e-9)
        assert r[k] == pytest.approx(d.site_xmat[tip].reshape(3, 3), abs=1e-9)
        mujoco.mj_jacSite(model, d, jacp, jacr, tip)
        assert jac[k, :3] == pytest.approx(jacp, abs=1e-9)  # position rows, world axes
        assert jac[k, 3:] == pytest.approx(chain.target_r.T @ jacr, abs=1e-9)  # angular rows, the target's axes
        assert e[k, :3] == pytest.approx(chain.target_p - d.site_xpos[tip], abs=1e-9)


def test_rotation_vectors_are_mujocos_including_half_turns():
    rng = np.random.default_rng(3)
    axes = rng.normal(size=(8, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.array([0.0, 1e-8, 0.3, 1.5, 3.0, np.pi - 1e-5, np.pi - 2e-3, 2.2])
    quats = np.column_stack([np.cos(angles / 2), axes * np.sin(angles / 2)[:, None]])
    mats = np.empty((8, 9))
    for q, m in zip(quats, mats):
        mujoco.mju_quat2Mat(m, q)
    got = ik_batch.rotation_vectors(mats.reshape(8, 3, 3))
    for k in range(8):
        want = np.empty(3)
        mujoco.mju_quat2Vel(want, quats[k], 1.0)  # the rotation vector, in the rotated frame = world here
        if angles[k] > np.pi - 1e-2:  # a half turn's vector is defined up to its sign
            assert min(np.linalg.norm(got[k] - want), np.linalg.norm(got[k] + want)) < 1e-4
        else:
            assert got[k] == pytest.approx(want, abs=1e-7)


def test_solutions_reach_the_target_in_mujocos_kinematics(rig):
    model, _, chain, tip, target = rig
    rng = np.random.default_rng(5)
    low, high = model.jnt_range[:, 0], model.jnt_range[:, 1]
    q, ok, err = chain.solve(rng.uniform(low, high, (64, model.njnt)), low, high, high, 0.05, 100,
                             np.ones(model.njnt))
    assert ok.sum() >= 3 and (err[ok] <= np.hypot(1e-4, 1e-3) + 1e-12).all()  # within the element's precision
    d = mujoco.MjData(model)
    for row in q[ok]:
        assert ((row >= low - 1e-12) & (row <= high + 1e-12)).all()
        d.qpos[:] = row
        mujoco.mj_kinematics(model, d)
        assert np.linalg.norm(d.site_xpos[tip] - target[0]) <= 1e-4
        rel = target[1].T @ d.site_xmat[tip].reshape(3, 3)
        assert np.arccos(np.clip((np.trace(rel) - 1) / 2, -1, 1)) <= 1e-3
    gate = chain.gate(q[ok], np.array([1.0, 1.0, 1.0, 0.1]))
    assert (gate <= 1e-3).all()


def test_a_target_that_moves_with_the_chain_is_not_batched():
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    tip = model.site("tip").id
    pose = (data.site_xpos[tip].copy(), data.site_xmat[tip].reshape(3, 3).copy())
    carried = model.body("l3").id
    assert ik_batch.Chain.build(model, data, list(range(model.njnt)), pose, int(model.site_bodyid[tip]), pose,
                                carried, np.eye(3), 31, (1.0, 1.0), (1e-4, 1e-3)) is None
    # a joint that does not carry the tip
    assert ik_batch.Chain.build(model, data, [0, 1], pose, model.body("base").id, pose, -1, np.eye(3), 31,
                                (1.0, 1.0), (1e-4, 1e-3)) is None
