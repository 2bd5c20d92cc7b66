"""A wheeled robot of a converted scene rests on its motored wheels, as Bullet's rigid contacts
rest it, and turns in place (simx_server/scene/ttt/parts.py, ``wheel_contacts``). Its two casters
stand 0.04 mm higher than its wheels' line; MuJoCo's soft contacts had shared its weight among all
four supports, and the casters (cylinders that roll only forward, as PyRep's TurtleBot has them)
dragged sideways slowed a turn in place (PyRep's TurtleBot: 0.0003 rad/s where its wheels ask
for 0.61)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.scene.ttt.parts import WHEEL_MARGIN

pytestmark = pytest.mark.renderers_on_demand  # no image is read

#: A joint's z axis along the world's y axis: a quarter turn about x.
_ALONG_Y = (math.cos(math.pi / 4), -math.sin(math.pi / 4), 0.0, 0.0)
RADIUS, TRACK, CASTER = 0.035, 0.2, 0.01  # wheel radius, wheel distance, caster radius (m)
RAISED = 4e-5  # how much higher the casters' lowest points stand than the wheels' (m)


def _scene() -> bytes:
    """A 2 kg chassis (its centre of mass 2 mm behind the wheels' axle) on two motored wheels
    in velocity mode, each hanging on a free drop joint held at its upper limit (as PyRep's
    TurtleBot), two casters on free hinges and a motored knob on top, on a static floor."""
    diameter = 2 * RADIUS
    parts = W.cuboid_shape(1, -1, "Floor", (4.0, 4.0, 0.1), (0, 0, -0.05), dynamic=False)
    parts += W.cuboid_shape(2, -1, "Chassis", (0.2, 0.16, 0.04), (-0.002, 0, 0.06), mass=2.0,
                            moments=(0.005, 0.007, 0.011), extra=W.model_base())  # the robot is a model
    for k, (name, y) in enumerate((("Left", TRACK / 2), ("Right", -TRACK / 2))):  # each on a drop joint
        h = 10 + 4 * k
        parts += W.joint(h, 2, f"{name}Drop", (0.002, y, RADIUS - 0.06), kind=11, motor=False, limits=(-0.01, 0.01))
        parts += W.cuboid_shape(h + 1, h, f"{name}Carrier", (0.04, 0.01, 0.04), mass=0.4, respondable=False,
                                moments=(1e-4, 1e-4, 1e-4))
        parts += W.joint(h + 2, h + 1, f"{name}Motor", (0, 0, 0), _ALONG_Y, motor=True, loop=False, max_force=0.3,
                         cyclic=True)
        parts += W.cuboid_shape(h + 3, h + 2, f"{name}Wheel", (diameter, diameter, 0.02), mass=0.06,
                                moments=(3.4e-4, 3.4e-4, 6.1e-4), primitive=5)
    for k, (name, x) in enumerate((("Front", 0.09), ("Back", -0.09))):
        parts += W.joint(20 + 2 * k, 2, f"{name}CasterHinge", (x + 0.002, 0, CASTER + RAISED - 0.06), _ALONG_Y,
                         motor=False, cyclic=True)
        parts += W.cuboid_shape(21 + 2 * k, 20 + 2 * k, f"{name}Caster", (2 * CASTER, 2 * CASTER, 0.01), mass=0.01,
                                moments=(3.3e-5, 3.3e-5, 5e-5), primitive=5)
    parts += W.joint(30, 2, "KnobMotor", (0, 0, 0.03), _ALONG_Y, motor=True, loop=False, cyclic=True)
    parts += W.cuboid_shape(31, 30, "Knob", (0.02, 0.02, 0.01), mass=0.01, moments=(1e-6, 1e-6, 1e-6),
                            primitive=5)  # round, motored, horizontal, but on top: no wheel
    return W.ttt_file(parts)


def _loads(w, bodies: dict[str, int]) -> dict[str, float]:
    """Normal force (N) of each body's contacts."""
    m, d = w.model, w.data
    out = dict.fromkeys(bodies, 0.0)
    f6 = np.zeros(6)
    for i in range(d.ncon):
        c = d.contact[i]
        mujoco.mj_contactForce(m, d, i, f6)
        for name, b in bodies.items():
            if b in (m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]):
                out[name] += float(f6[0])
    return out


def test_a_wheeled_robot_rests_on_its_wheels_and_turns_in_place(tmp_path):
    (tmp_path / "bot.ttt").write_bytes(_scene())
    xml, _ = convert.convert(reader.read(str(tmp_path / "bot.ttt")), tmp_path / "out", "bot")
    m = mujoco.MjModel.from_xml_path(str(xml))
    margins = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])): float(m.geom_margin[g])
               for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]}
    assert margins["LeftWheel"] == margins["RightWheel"] == WHEEL_MARGIN  # motored, round, horizontal
    assert margins["FrontCaster"] == margins["BackCaster"] == margins["Chassis"] == 0.0  # free hinges, a box
    assert margins["Knob"] == 0.0  # not among the robot's lowest points
    sim = Simulation(xml, realtime=False)
    try:
        w = sim.world
        bodies = {n: w.by_name[n].body for n in ("LeftWheel", "RightWheel", "FrontCaster", "BackCaster")}
        sim.start()
        for _ in range(20):  # 1 s to settle
            sim.step()
        loads = _loads(w, bodies)
        weight = float(m.body_subtreemass[w.by_name["Chassis"].body]) * 9.81
        assert sum(loads.values()) == pytest.approx(weight, rel=0.02)
        casters = loads["FrontCaster"] + loads["BackCaster"]
        assert casters < 0.05 * weight, loads  # Bullet's statics: the back caster, 2 mm / 9 cm of it (without
        # the margin: a fifth of the weight)
        chassis = w.by_name["Chassis"].body
        yaw0 = _yaw(w.data.xmat[chassis])
        w.set_joint_target_velocity(w.by_name["LeftMotor"].handle, -2.0)
        w.set_joint_target_velocity(w.by_name["RightMotor"].handle, 2.0)
        steps = 20
        for _ in range(steps):
            sim.step()
        rate = _wrapped(_yaw(w.data.xmat[chassis]) - yaw0) / (steps * w.dt)
        rolling = RADIUS * 4.0 / TRACK  # rad/s: the wheels rolling without slip
        assert rate > 0.8 * rolling, (rate, rolling)  # without the margin: 0.48 of 0.70 rad/s
    finally:
        sim.stop()
        sim.close()


def _yaw(xmat: np.ndarray) -> float:
    return math.atan2(float(xmat[3]), float(xmat[0]))


def _wrapped(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi
