"""``Arm.get_nonlinear_path`` plans with OMPL through the table's simOMPL (PyRep's add-on does so
with CoppeliaSim's simOMPL): PyRep's Panda (../shared/pyrep/robot_ttms, skipped without it,
failing under CI) turning its base by 90 degrees past a pillar that the straight joint-space
line hits."""

from __future__ import annotations

import logging
from enum import Enum

import numpy as np
import pytest

from pyrep.const import ConfigurationPathAlgorithms as Algos, PrimitiveShape
from pyrep.objects import Shape

try:
    from conftest import SHARED, require_shared
except ImportError:
    from tests.conftest import SHARED, require_shared

pytest.importorskip("ompl")
MODELS = SHARED / "pyrep" / "robot_ttms"


@pytest.fixture
def panda(pr):
    """The Panda, a goal pose 90 degrees round its base, and a pillar half way there."""
    from pyrep.robots.arms.panda import Panda

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "arms" / "Panda.ttm")))
    pr.start()
    arm = Panda()
    tip = arm.get_tip()
    start = np.array(arm.get_joint_positions())
    turned = start.copy()
    turned[0] += np.pi / 4
    arm.set_joint_positions(turned.tolist())
    half_way = tip.get_position()
    turned[0] += np.pi / 4
    arm.set_joint_positions(turned.tolist())
    goal, orientation = tip.get_position(), tip.get_quaternion()
    arm.set_joint_positions(start.tolist())
    pillar = Shape.create(PrimitiveShape.CUBOID, [0.1, 0.1, 0.3], position=half_way.tolist(), static=True)
    pillar.set_collidable(True)  # CoppeliaSim 4.1 creates it not collidable
    return arm, start, goal, orientation, pillar


def _hits(arm, configs, pillar) -> list[bool]:
    hits = []
    for q in configs:
        arm.set_joint_positions(list(q))
        hits.append(arm.check_arm_collision(pillar))
    return hits


def test_the_path_goes_round_the_pillar_that_the_straight_line_hits(panda):
    arm, start, goal, orientation, pillar = panda
    # RLBench's ten searches: PyRep keeps a search's path only when every one of its 300
    # states is valid, and one that hugs the pillar can touch it between the checked states
    path = arm.get_nonlinear_path(goal, quaternion=orientation, algorithm=Algos.RRTConnect, trials_per_goal=10)
    assert np.allclose(arm.get_joint_positions(), start)  # planning did not move the arm
    configs = path._path_points.reshape(-1, 7)
    assert np.allclose(configs[0], start, atol=1e-6)
    assert len(configs) == 300  # simOMPL.compute(task, 4, -1, 300), as PyRep's _findPath
    straight = [start + f * (configs[-1] - start) for f in np.linspace(0, 1, 60)]
    assert any(_hits(arm, straight, pillar))
    assert not any(_hits(arm, configs, pillar))
    path.set_to_end()
    assert np.linalg.norm(arm.get_tip().get_position() - goal) < 0.01


def test_planning_puts_the_target_dummy_back(panda):
    """PyRep's get_linear_path and solve_ik_via_sampling (so get_nonlinear_path) move the IK
    target to the goal for CoppeliaSim's IK and put it back where it was."""
    from pyrep.objects.dummy import Dummy

    arm, start, goal, orientation, pillar = panda
    target = Dummy("Panda_target")
    before = target.get_pose()
    near = arm.get_tip().get_position() + np.array([0.0, 0.0, -0.05])
    arm.get_linear_path(near, quaternion=arm.get_tip().get_quaternion())
    assert np.allclose(target.get_pose(), before)
    arm.get_nonlinear_path(goal, quaternion=orientation, algorithm=Algos.RRTConnect, trials_per_goal=10)
    assert np.allclose(target.get_pose(), before)


def test_an_algorithm_the_bindings_lack_plans_with_rrt_connect_and_says_so(panda, caplog, monkeypatch):
    from pyrep.backend import sim

    arm, _, goal, orientation, pillar = panda
    monkeypatch.setattr(sim, "_SUBSTITUTED", set())  # as in a new process
    with caplog.at_level(logging.WARNING, logger="pyrep"):
        path = arm.get_nonlinear_path(goal, quaternion=orientation, trials_per_goal=10)  # PyRep's default: SBL
        arm.get_nonlinear_path(goal, quaternion=orientation, algorithm=Algos.SBL, trials_per_goal=10)
    warned = [r.getMessage() for r in caplog.records if "SBL" in r.getMessage()]
    assert len(warned) == 1 and "planning with RRTConnect instead" in warned[0]  # once per process
    assert not any(_hits(arm, path._path_points.reshape(-1, 7), pillar))
    path = arm.get_nonlinear_path(goal, quaternion=orientation, algorithm=Algos.PRM, trials_per_goal=10)
    assert not any(_hits(arm, path._path_points.reshape(-1, 7), pillar))


def test_a_bad_algorithm_gives_pyreps_errors(panda):
    arm, _, goal, orientation, _ = panda
    with pytest.raises(AttributeError, match="value"):  # PyRep reads algorithm.value
        arm.get_nonlinear_path(goal, quaternion=orientation, algorithm="RRTConnect")
    with pytest.raises(RuntimeError, match="pRRT"):  # CoppeliaSim's simOMPL has no parallel planner
        arm.get_nonlinear_path(goal, quaternion=orientation, algorithm=Algos.pRRT)
    Other = Enum("Other", {"Foo": "Foo"})  # noqa: N806
    with pytest.raises(RuntimeError, match="no algorithm 'Foo'"):
        arm.get_nonlinear_path(goal, quaternion=orientation, algorithm=Other.Foo)


def test_a_pyrep_connected_over_zmq_plans_on_the_server(pyrep_scene):
    from pyrep import PyRep
    from pyrep.robots.arms.panda import Panda

    try:
        from conftest import ServerProcess, free_port
    except ImportError:
        from tests.conftest import ServerProcess, free_port

    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    model = require_shared(MODELS / "arms" / "Panda.ttm")
    port = free_port()
    server = ServerProcess(str(pyrep_scene), "--stopped", "--zmq-port", str(port), "--scene-path", str(model.parent))
    pr = PyRep()
    try:
        pr.connect("127.0.0.1", port)
        pr.import_model(str(model))
        pr.start()
        arm = Panda()
        start = np.array(arm.get_joint_positions())
        goal = start.copy()
        goal[0] += 0.5
        arm.set_joint_positions(goal.tolist())
        pose = arm.get_tip().get_position(), arm.get_tip().get_quaternion()
        arm.set_joint_positions(start.tolist())
        path = arm.get_nonlinear_path(pose[0], quaternion=pose[1], algorithm=Algos.RRTConnect)
        configs = path._path_points.reshape(-1, 7)
        assert len(configs) > 2 and np.allclose(configs[0], start, atol=1e-6)
        path.set_to_end()
        assert np.linalg.norm(arm.get_tip().get_position() - pose[0]) < 0.01
    finally:
        pr.shutdown()
        server.stop()


class _Calls:
    """Counts the table's ``simIK`` and ``simOMPL`` calls by name (``pyrep.backend.sim``)."""

    def __init__(self, monkeypatch):
        from pyrep.backend import sim

        self.count: dict[str, int] = {}
        for wrapper in ("ik_call", "ompl_call"):
            real = getattr(sim, wrapper)

            def call(name, *args, real=real):
                self.count[name] = self.count.get(name, 0) + 1
                return real(name, *args)

            monkeypatch.setattr(sim, wrapper, call)


def test_a_pose_out_of_reach_ends_after_trials_tries_of_max_time_ms(panda, monkeypatch):
    """PyRep's bound: ``trials`` searches of ``max_time_ms`` each (sim.getConfigForTipPose's),
    IK solved only from configurations within ``distance_threshold`` of the target, no planning
    without a goal."""
    from pyrep.errors import ConfigurationError, ConfigurationPathError
    from pyrep.robots.arms import sampling

    arm, start, *_ = panda
    calls = _Calls(monkeypatch)
    with pytest.raises(ConfigurationError):
        arm.solve_ik_via_sampling([9.0, 9.0, 9.0], euler=[0.0, 0.0, 0.0], trials=4, max_time_ms=20)
    # IK solved once, from the current configuration (the first try); random ones are never near
    assert calls.count["findConfig"] == 1
    assert np.allclose(arm.get_joint_positions(), start)
    # a clock that moves 0.5 s per reading: the search ends at 3 s (300 x 10 ms), after the first
    # try (IK from the current configuration) and five tries of random starts (at 0.5 ... 2.5)
    clock = iter(np.arange(0.0, 1000.0, 0.5))
    monkeypatch.setattr(sampling, "monotonic", lambda: float(next(clock)))
    calls.count.clear()
    with pytest.raises(ConfigurationPathError):
        arm.get_nonlinear_path([9.0, 9.0, 9.0], euler=[0.0, 0.0, 0.0], trials=300, max_time_ms=10)
    assert calls.count["findConfig"] == 1 and calls.count["findConfigs"] == 5
    assert "createTask" not in calls.count


def test_a_linear_path_turns_about_the_axis_of_a_half_turn(pr):
    """The poses of ``get_linear_path`` without an IK group (``planning.interpolate_poses``) turn
    about the rotation's own axis, a half turn included (sim.interpolateMatrices): the axis of a
    half turn is not in the antisymmetric part of its matrix, which is zero."""
    from pyrep.robots.arms import planning

    start, goal = np.eye(4), np.eye(4)
    goal[:3, :3] = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]  # pi about x
    goal[:3, 3] = [0.2, 0.0, 0.4]
    poses = planning.interpolate_poses(start, goal, 4)
    assert len(poses) == 4 and np.allclose(poses[-1], goal, atol=1e-9)
    half = poses[1][:3, :3]  # half way: a quarter turn about x, either way round
    assert np.allclose(half[:, 0], [1, 0, 0], atol=1e-9) and abs(half[2, 1]) == pytest.approx(1.0)
    assert np.allclose(poses[1][:3, 3], [0.1, 0.0, 0.2])


def test_the_ik_error_of_a_half_turn_is_the_turn_about_its_axis(panda):
    """The damped least squares of an arm without an IK group steps along the tip's error: its
    angular part, the rotation vector to the goal (rad), is pi about the axis of a half turn (the
    table's sim.getRotationAxis), where dividing by sin(pi) gave noise."""
    arm = panda[0]
    tip = arm.get_tip().get_matrix()
    goal = tip.copy()
    goal[:3, :3] = tip[:3, :3] @ np.diag([1.0, -1.0, -1.0])  # pi about the tip's own x axis
    goal[:3, 3] += [0.01, 0.0, 0.0]
    err = arm._error(goal)
    assert np.allclose(err[:3], [0.01, 0.0, 0.0], atol=1e-9)
    axis = tip[:3, 0]  # the tip's x in the world, either way round
    assert np.allclose(np.abs(err[3:]), np.abs(np.pi * axis), atol=1e-6)
