"""PyRep's mobile bases on simx: PyRep's youBot (holonomic), TurtleBot and LineTracer
(nonholonomic) models (../shared/pyrep/robot_ttms/mobiles, skipped without it, failing under
CI), driven by their wheels and along linear and planned paths (simOMPL's ``dubins`` state
space, collisions checked by MuJoCo on a scratch copy of the state).

The youBot is the scene itself (``launch`` of its ``.ttm``), and once added to an empty scene
with ``import_model``: its omni-wheels work through the model's scripts, which come with it
either way; a floor that is neither collidable nor measurable is added under it, as
CoppeliaSim's default floor."""

from __future__ import annotations

import numpy as np
import pytest

from pyrep.const import PrimitiveShape
from pyrep.errors import ConfigurationPathError
from pyrep.objects import Shape

try:
    from conftest import SHARED, require_shared
except ImportError:
    from tests.conftest import SHARED, require_shared

pytest.importorskip("ompl")
MOBILES = SHARED / "pyrep" / "robot_ttms" / "mobiles"


def _floor() -> Shape:
    floor = Shape.create(PrimitiveShape.CUBOID, [6.0, 6.0, 0.1], position=[0.0, 0.0, -0.05], static=True,
                         respondable=True)
    floor.set_collidable(False)
    floor.set_measurable(False)
    return floor


def _box(x: float, y: float, size: float) -> Shape:
    """A static obstacle of ``size`` m standing on the floor at (x, y)."""
    box = Shape.create(PrimitiveShape.CUBOID, [size] * 3, position=[x, y, size / 2], static=True, respondable=True)
    box.set_collidable(True)  # CoppeliaSim 4.1 creates it not collidable
    return box


@pytest.fixture
def youbot():
    """PyRep's youBot on a floor, at the origin facing -x (its front is its y axis), started."""
    from pyrep import PyRep
    from pyrep.robots.mobiles.youbot import YouBot

    pr = PyRep()
    pr.launch(str(require_shared(MOBILES / "youBot.ttm")), headless=True)
    try:
        _floor()
        yield pr, YouBot
    finally:
        pr.shutdown()


@pytest.fixture
def empty():
    """PyRep's empty scene (its floor neither collidable nor measurable, as CoppeliaSim's)."""
    from pyrep import PyRep

    pr = PyRep()
    pr.launch("", headless=True)
    yield pr
    pr.shutdown()


def _start(pr, kind, pose):
    pr.start()
    bot = kind()
    bot.set_2d_pose(pose)
    for _ in range(5):  # it settles on its wheels
        pr.step()
    return bot


def _follow(pr, bot, path, limit: int) -> bool:
    """Steps along ``path`` until done; whether the base collided on the way."""
    return _track(pr, bot, path, limit)[0]


def _track(pr, bot, path, limit: int) -> tuple[bool, float]:
    """Steps along ``path`` until done: whether the base collided on the way, and its largest
    distance (m) from the path's nearest point."""
    points = np.array(path._path_points)[:, :2]
    hit, steps, off = False, 0, 0.0
    while not path.step():
        pr.step()
        hit |= bot.assess_collision()
        off = max(off, float(np.linalg.norm(points - bot.get_2d_pose()[:2], axis=1).min()))
        steps += 1
        assert steps < limit
    pr.step()
    return hit, off


def _settle(pr, bot, steps: int, holonomic: bool) -> None:
    """The base's own controller towards its target for at most ``steps`` steps, as after a
    planned path (whose step() says done once its last point is the target). A holonomic base
    turns to its intermediate target's yaw, the goal's box-adjusted facing angle; PyRep's
    controller is done only when the goal's yaw less the base's is below 0.1 degree (signed): it
    may never be, the base held at the goal."""
    for _ in range(steps):
        actuation, done = bot.get_base_actuation()
        if done:
            return
        (bot.set_base_angular_velocites if holonomic else bot.set_joint_target_velocities)(actuation)
        pr.step()


@pytest.mark.parametrize("command", ["forward", "sideways", "turn"])
def test_youbot_drives_forward_sideways_and_turns(youbot, command):
    pr, kind = youbot
    bot = _start(pr, kind, [0.0, 0.0, np.pi / 2])
    x0, y0, yaw0 = bot.get_2d_pose()
    bot.set_base_angular_velocites({"forward": [5, 0, 0], "sideways": [0, 5, 0], "turn": [0, 0, 2]}[command])
    for _ in range(40):  # 2 s
        pr.step()
    x, y, yaw = bot.get_2d_pose()
    ahead, aside = -(x - x0), y - y0  # its y axis (its front) is the world's -x here
    if command == "forward":  # 5 rad/s of 5 cm wheels: 0.25 m/s
        assert ahead > 0.4 and abs(aside) < 0.05 and abs(yaw - yaw0) < 0.05
    elif command == "sideways":
        assert aside > 0.2 and abs(ahead) < 0.1 and abs(yaw - yaw0) < 0.2
    else:  # a positive rotation turns it clockwise
        assert yaw - yaw0 < -0.3 and np.hypot(ahead, aside) < 0.05
    fb, lr, rot = 1.0, 2.0, 3.0
    bot.set_base_angular_velocites([fb, lr, rot])
    assert np.allclose(bot.get_joint_target_velocities(),
                       [-fb - lr - rot, -fb + lr - rot, -fb - lr + rot, -fb + lr + rot])


def test_youbot_follows_a_linear_path_to_a_waypoint(youbot):
    """PyRep's test_get_linear_path_and_step: within 1 mm of the waypoint in x and y."""
    from pyrep.objects.dummy import Dummy

    pr, kind = youbot
    bot = _start(pr, kind, [0.0, 0.0, np.pi / 2])
    waypoint = Dummy.create()
    waypoint.set_position([-0.8, 0.3, 0.0])
    path = bot.get_linear_path(waypoint.get_position(), waypoint.get_orientation()[-1])
    assert np.allclose(bot.get_2d_pose()[:2], [0.0, 0.0], atol=1e-3)  # checking it did not move it
    assert not _follow(pr, bot, path, 600)
    assert np.allclose(bot.get_position()[:2], waypoint.get_position()[:2], atol=0.001)
    path.set_to_end()
    assert np.allclose(bot.get_position()[:2], waypoint.get_position()[:2], atol=0.001)


def test_youbot_plans_round_an_obstacle_that_the_straight_path_hits(youbot):
    pr, kind = youbot
    _box(-0.8, 0.0, 0.3)
    bot = _start(pr, kind, [0.0, 0.0, np.pi / 2])
    goal = [-1.6, 0.0]
    with pytest.raises(ConfigurationPathError, match="linear path"):
        bot.get_linear_path(goal, np.pi / 2)
    qpos = pr.simulation.world.data.qpos.copy()
    path = bot.get_nonlinear_path(goal, np.pi / 2)
    assert np.allclose(pr.simulation.world.data.qpos[:3], qpos[:3], atol=1e-3)  # planning left the base
    points = np.array(path._path_points)
    assert points.shape == (600, 4) and np.allclose(points[-1, :3], [-1.6, 0.0, np.pi / 2], atol=1e-6)
    assert np.allclose(points[1:, 3], np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1))
    assert max(abs(points[:, 1])) > 0.3  # round the box
    path.visualize()  # a drawing object of the base's positions (kept as data)
    path.clear_visualization()
    assert not _follow(pr, bot, path, 3000)  # it never touched the box
    _settle(pr, bot, 300, holonomic=True)
    assert np.allclose(bot.get_position()[:2], goal, atol=0.001)
    # facing the goal's box-adjusted angle: the goal's yaw give or take quarter turns
    off = np.remainder(bot.get_2d_pose()[2] - np.pi / 2 + np.pi / 4, np.pi / 2) - np.pi / 4
    assert abs(off) < 0.01
    assert not bot.assess_collision()


def test_turtlebot_turns_in_place_on_its_wheels(empty):
    """At -2 and 2 rad/s on its wheels the TurtleBot turns at 0.61 rad/s where they roll without
    slip, on CoppeliaSim's rigid contacts; its casters roll only forward and are dragged
    sideways. It turned at 0.0003 rad/s while MuJoCo's soft contacts put half its weight on
    them (docs/PYREP.md); its wheels' contact margin (docs/PORTING.md) leaves it on its wheels."""
    from pyrep.robots.mobiles.turtlebot import TurtleBot

    pr = empty
    pr.import_model(str(require_shared(MOBILES / "turtlebot.ttm")))
    bot = _start(pr, TurtleBot, [0.0, 0.0, 0.0])
    bot.set_joint_target_velocities([-2.0, 2.0])
    for _ in range(20):  # 1 s
        pr.step()
    assert bot.get_2d_pose()[2] > 0.5


def test_turtlebot_follows_a_linear_path_and_a_planned_one_round_a_box(empty):
    """Its linear path starts 1.2 rad off the goal's bearing: the base turns on its wheels."""
    from pyrep.robots.mobiles.turtlebot import TurtleBot

    pr = empty
    pr.import_model(str(require_shared(MOBILES / "turtlebot.ttm")))
    bot = _start(pr, TurtleBot, [-1.0, -0.5, 1.5])
    goal = [0.5, 0.0]
    path = bot.get_linear_path(goal, 0.0)
    assert not _follow(pr, bot, path, 1000)
    assert np.linalg.norm(bot.get_position()[:2] - goal) < 0.1  # PyRep's controller stops within 0.1 m
    assert bot.get_base_actuation() == ([0.0, 0.0], True)
    _box(1.2, 0.0, 0.2)
    with pytest.raises(ConfigurationPathError, match="linear path"):
        bot.get_linear_path([1.8, 0.0], 0.0)
    path = bot.get_nonlinear_path([1.8, 0.0], 0.0, path_pts=100)
    hits = 0
    for point in path._path_points:  # the planned path's points are free: OMPL checks its motions
        bot.set_2d_pose(point[:3])  # every ~1.5 cm, so a point between two checks may graze, once
        hits += bot.assess_collision()
    assert hits <= 1
    path.set_to_start()
    assert np.allclose(bot.get_2d_pose(), path._path_points[0][:3], atol=1e-3)
    # PyRep's nonholonomic controller steers at a point ahead on the path and cuts its curves
    # (the LineTracer's test below): the base stays near the path and stops at the goal
    assert _track(pr, bot, path, 3000)[1] < 0.15
    _settle(pr, bot, 1000, holonomic=False)
    assert np.linalg.norm(bot.get_position()[:2] - [1.8, 0.0]) < 0.15


def test_line_tracer_follows_a_planned_path_round_a_box(empty):
    from pyrep.robots.mobiles.line_tracer import LineTracer

    pr = empty
    pr.import_model(str(require_shared(MOBILES / "LineTracer.ttm")))
    _box(0.5, 0.0, 0.2)
    bot = _start(pr, LineTracer, [0.0, 0.0, 0.0])
    with pytest.raises(ConfigurationPathError):
        bot.get_linear_path([1.0, 0.0], 0.0)
    path = bot.get_nonlinear_path([1.0, 0.0], 0.0)
    assert max(abs(np.array(path._path_points)[:, 1])) > 0.1
    # PyRep's nonholonomic controller steers at a point ahead on the path and cuts its curves
    # (measured: up to 8 cm off in 40 plans), so a planned path that grazes the box (its states
    # are checked, not their neighbourhood) may be touched on the way, in CoppeliaSim as here
    assert _track(pr, bot, path, 3000)[1] < 0.15
    _settle(pr, bot, 1000, holonomic=False)
    assert bot.get_base_actuation()[1]
    # PyRep's controller: done within 0.1 m of the goal seen in the base's frame; the base rests
    # pitched 0.12 rad on its caster, so the goal dummy's height (0.1 m) adds about 1 cm there
    assert np.linalg.norm(bot.target_base.get_position(relative_to=bot)[:2]) < 0.1
    assert np.linalg.norm(bot.get_position()[:2] - [1.0, 0.0]) < 0.12
    with pytest.raises(RuntimeError, match="already been completed"):
        path.step()


def test_planning_errors_are_pyreps(empty):
    from pyrep.const import ConfigurationPathAlgorithms as Algos
    from pyrep.robots.mobiles.line_tracer import LineTracer
    from pyrep.robots.mobiles.locobot import LoCoBot

    with pytest.raises(RuntimeError, match="LoCoBot"):  # its model is not in the scene (nor in ../shared)
        LoCoBot()
    pr = empty
    pr.import_model(str(require_shared(MOBILES / "LineTracer.ttm")))
    _box(1.0, 1.0, 0.2)
    bot = _start(pr, LineTracer, [0.0, 0.0, 0.0])
    with pytest.raises(ConfigurationPathError):  # the goal inside the box
        bot.get_nonlinear_path([1.0, 1.0], 0.0)
    with pytest.raises(AttributeError, match="value"):  # PyRep reads algorithm.value
        bot.get_nonlinear_path([1.0, 0.0], 0.0, algorithm="RRTConnect")
    with pytest.raises(RuntimeError, match="pSBL"):
        bot.get_nonlinear_path([1.0, 0.0], 0.0, algorithm=Algos.pSBL)
    path = bot.get_nonlinear_path([1.0, 0.0], 0.0, algorithm=Algos.PRM, path_pts=50)
    assert len(path._path_points) == 50
    copy = bot.copy()
    assert copy != bot and LineTracer(1) == copy


def test_a_youbot_imported_as_a_model_slides_sideways(empty):
    """``import_model`` brings the model's scripts, which keep its mecanum wheels' rollers at
    45 degrees: it slides sideways as the scene that holds it does (CoppeliaSim's ``loadModel``)."""
    from pyrep.robots.mobiles.youbot import YouBot

    pr = empty
    pr.import_model(str(require_shared(MOBILES / "youBot.ttm")))
    bot = _start(pr, YouBot, [0.0, 0.0, np.pi / 2])
    x0, y0, yaw0 = bot.get_2d_pose()
    bot.set_base_angular_velocites([0, 5, 0])
    for _ in range(40):  # 2 s
        pr.step()
    x, y, yaw = bot.get_2d_pose()
    ahead, aside = -(x - x0), y - y0
    assert aside > 0.2 and abs(ahead) < 0.1 and abs(yaw - yaw0) < 0.2
