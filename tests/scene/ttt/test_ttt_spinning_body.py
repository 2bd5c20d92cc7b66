"""A converted scene integrates gyroscopic forces stably (MuJoCo's ``implicit`` integrator, not
``implicitfast``): a wheeled robot that drove off its floor (real4/zmq_lumibot_wall, 0.2 kg with
two 0.05 kg wheels turning) fell spinning at 24 rad/s about its long axis; under ``implicitfast``
its wobble grew until MuJoCo found a NaN and the simulation stopped for every client. Bullet 2.78
(CoppeliaSim 4.1's default engine) applies no gyroscopic force at all; MuJoCo's ``implicit``
keeps the body's spin as a rigid body keeps it."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read

#: A joint's z axis along the body's y axis: a quarter turn about x.
_ALONG_Y = (math.cos(math.pi / 4), -math.sin(math.pi / 4), 0.0, 0.0)


def test_a_falling_spinning_wheeled_body_keeps_its_spin(tmp_path):
    body = (W.cuboid_shape(1, -1, "Bot", (0.06, 0.06, 0.03), (0, 0, 50), mass=0.2, moments=(6e-4, 3.75e-4, 3.75e-4))
            + W.joint(2, 1, "LeftMotor", (0, 0.03, 0), _ALONG_Y, target_velocity=2.0, max_force=1.0, cyclic=True)
            + W.cuboid_shape(3, 2, "LeftWheel", (0.05, 0.05, 0.005), (0, 0, 0), mass=0.05,
                             moments=(1.55e-4, 1.55e-4, 3.06e-4))
            + W.joint(4, 1, "RightMotor", (0, -0.03, 0), _ALONG_Y, target_velocity=2.0, max_force=1.0, cyclic=True)
            + W.cuboid_shape(5, 4, "RightWheel", (0.05, 0.05, 0.005), (0, 0, 0), mass=0.05,
                             moments=(1.55e-4, 1.55e-4, 3.06e-4)))
    f = tmp_path / "bot.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "bot")
    sim = Simulation(xml, realtime=False)
    try:
        sim.start()
        w = sim.world
        dof = int(w.model.jnt_dofadr[next(j for j in range(w.model.njnt) if w.model.jnt_type[j] == 0)])
        w.data.qvel[dof + 3:dof + 6] = [24.0, 0.1, -0.1]  # spinning about its long (x) axis, a little off
        for _ in range(int(30.0 / w.dt)):
            w.step()  # raises PhysicsError once MuJoCo finds the NaN
        spin = w.data.qvel[dof + 3:dof + 6]
        assert spin[0] == pytest.approx(24.0, abs=1.0)
        assert np.hypot(spin[1], spin[2]) < 1.0  # implicitfast: 20 rad/s at 30 s, then a NaN
    finally:
        sim.stop()
        sim.close()
