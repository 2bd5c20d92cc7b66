"""A revolute joint CoppeliaSim saved at the end of its interval (issue 50: the UR3 of
"Libro-CoppeliaSim" chapters 19-20, its joints at +2*pi or -2*pi of a [-2*pi, +2*pi] interval).

coppeliaSimLib ``CJoint::serialize`` stores the interval as minimum and range (``_mr``/``Pmr``),
the position (``_rt``/``Prt``) and cyclic as ``Va9`` bit 0; ``CJoint::setPosition`` clamps a
non-cyclic joint into ``[min, min + range]``, which is how a joint gets saved exactly at a limit.
The joint converts as a limited hinge with its position at that limit, and simIK keeps it inside
(coppeliaKinematicsRoutines ``CJoint::setPosition`` clamps each step of ``CikGroup::applyDq``)
and, at its upper limit, where it is: the numeric Jacobian moves each joint up through that clamp.
At its lower limit it keeps its column, so a target that pushes it outwards stalls the chain.
"""

from __future__ import annotations

import numpy as np
import pytest

import tttwriter as W
from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read

LOW, RANGE = -1.0, 2.0  # J1's interval: [-1, 1] rad, saved at its upper end


def _arm() -> bytes:
    """Two-hinge arm; J1 saved at its upper limit (non-cyclic), J2 at 0.3 rad."""
    return (W.cuboid_shape(1, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.joint(2, 1, "J1", (0, 0, 0.15), quat=(0.7071068, 0.7071068, 0, 0), limits=(LOW, RANGE),
                      position=LOW + RANGE)
            + W.cuboid_shape(3, 2, "L1", (0.05, 0.3, 0.05), (0, 0.15, 0), mass=0.2)
            + W.joint(4, 3, "J2", (0, 0.15, 0), limits=(-3.0, 6.0), position=0.3)
            + W.cuboid_shape(5, 4, "L2", (0.05, 0.3, 0.05), (0, 0.15, 0), mass=0.2)
            + W.dummy(6, 5, "Tip", (0, 0.15, 0))
            + W.dummy(7, -1, "Target", (0, 0, 0.85)))


@pytest.fixture
def arm(tmp_path):
    f = tmp_path / "scene.ttt"
    f.write_bytes(W.ttt_file(_arm(), serialization=25, program=41000))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "scene")
    sim = Simulation(xml, realtime=False)
    yield sim
    sim.close()


def test_joint_saved_at_its_limit_converts_limited_at_that_limit(tmp_path):
    f = tmp_path / "scene.ttt"
    f.write_bytes(W.ttt_file(_arm(), serialization=25, program=41000))
    j1 = reader.read(f).objects[2].data
    assert (j1.cyclic, j1.minimum, j1.range, j1.position) == (False, LOW, RANGE, LOW + RANGE)
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "scene")
    sim = Simulation(xml, realtime=False)
    try:
        m, d = sim.world.model, sim.world.data
        jid = m.joint("J1").id
        assert bool(m.jnt_limited[jid])
        assert m.jnt_range[jid].tolist() == pytest.approx([LOW, LOW + RANGE])
        assert d.qpos[m.jnt_qposadr[jid]] == pytest.approx(LOW + RANGE)
    finally:
        sim.close()


def _tip_at(api, j1: int, j2: int, tip: int, q1: float, q2: float) -> list[float]:
    """The tip's world position with the joints at ``q1``, ``q2`` (simulation stopped)."""
    api.setJointPosition(j1, q1)
    api.setJointPosition(j2, q2)
    return api.getObjectPosition(tip, -1)


@pytest.mark.parametrize("start, q1, kept", [(LOW + RANGE, 0.0, True), (LOW + RANGE, 1.4, True), (LOW, -0.4, False)],
                         ids=["upper-limit", "past-the-limit", "lower-limit"])
def test_simik_keeps_a_joint_at_its_upper_limit_and_lets_one_leave_its_lower(arm, start, q1, kept):
    """The target is where the tip is with J1 at ``q1`` (J2 at 0.5), J1 starts at a limit.
    CoppeliaSim differentiates by moving each joint 0.01 up through ``CJoint::setPosition``,
    which clamps it (coppeliaKinematicsRoutines ``CikElement::_getNakedJacobian``): at its upper
    limit J1 has no Jacobian column, so the group leaves it there even for a target that needs
    it back inside (the tip stays short); from its lower limit it moves. Solved while the
    simulation is stopped, as a ``sysCall_nonSimulation`` does: the joints themselves move."""
    api, ik = client_context(arm).sim, client_context(arm).simik
    base, tip, target = api.getObject("/Base"), api.getObject("/Tip"), api.getObject("/Target")
    j1, j2 = api.getObject("/J1"), api.getObject("/J2")
    goal = _tip_at(api, j1, j2, tip, q1, 0.5)
    _tip_at(api, j1, j2, tip, start, 0.3)
    api.setObjectPosition(target, -1, goal)
    env = ik.createEnvironment()
    group = ik.createGroup(env)
    ik.setGroupCalculation(env, group, ik.method_damped_least_squares, 0.1, 10)
    ik.addElementFromScene(env, group, base, tip, target, ik.constraint_position)
    for _ in range(20):
        ik.handleGroup(env, group, {"syncWorlds": True, "allowError": True})
        assert LOW <= api.getJointPosition(j1) <= LOW + RANGE
    gap = float(np.linalg.norm(np.subtract(api.getObjectPosition(tip, -1), goal)))
    if kept:
        assert api.getJointPosition(j1) == start and gap > 0.02
    else:
        assert gap < 0.01 and api.getJointPosition(j1) > LOW + 0.1


def test_simik_stalls_a_chain_whose_joint_at_its_lower_limit_is_pushed_outwards(arm):
    """J1 at its lower limit, the target where the tip is with J1 0.2 rad further down (J2 at 0.8).
    From the lower limit the numeric Jacobian's +0.01 nudge is inside the interval, so J1 keeps
    its whole column (coppeliaKinematicsRoutines ``CikElement::_getNakedJacobian``); the damped
    step puts the motion on J1, ``CikGroup::applyDq`` clamps it away, and J2 gets only the share
    that assumed J1 moved: the group stalls, the tip no closer than it started. Made passive
    (no column), J1 would leave J2 to get within 0.035 m: the stall is the column's, not the
    geometry's (the UR3 of Libro-CoppeliaSim's pick_place.ttt was saved in such a stall)."""
    api, ik = client_context(arm).sim, client_context(arm).simik
    base, tip, target = api.getObject("/Base"), api.getObject("/Tip"), api.getObject("/Target")
    j1, j2 = api.getObject("/J1"), api.getObject("/J2")
    goal = _tip_at(api, j1, j2, tip, LOW - 0.2, 0.8)
    api.setObjectPosition(target, -1, goal)

    def solve(passive: bool) -> tuple[float, list[float]]:
        start = _tip_at(api, j1, j2, tip, LOW, 0.8)
        env = ik.createEnvironment()
        group = ik.createGroup(env)
        ik.setGroupCalculation(env, group, ik.method_damped_least_squares, 0.1, 10)
        ik.addElementFromScene(env, group, base, tip, target, ik.constraint_position)
        if passive:
            ik.setJointMode(env, j1, ik.jointmode_passive)
        q2 = []
        for _ in range(20):
            ik.handleGroup(env, group, {"syncWorlds": True, "allowError": True})
            q2.append(api.getJointPosition(j2))
        gap = float(np.linalg.norm(np.subtract(api.getObjectPosition(tip, -1), goal)))
        return gap / float(np.linalg.norm(np.subtract(start, goal))), q2

    kept, q2 = solve(passive=False)
    assert api.getJointPosition(j1) == LOW
    assert kept > 0.9 and abs(q2[-1] - q2[-2]) < 1e-9  # no closer, and at rest there
    without, _ = solve(passive=True)
    assert without < 0.4
