"""A converted scene integrates gyroscopic forces stably (MuJoCo's ``implicit`` integrator, not
``implicitfast``, while a body spins): a wheeled robot that drove off its floor
(real4/zmq_lumibot_wall, 0.2 kg with two 0.05 kg wheels turning) fell spinning at 24 rad/s about
its long axis; under ``implicitfast`` its wobble grew until MuJoCo found a NaN and the simulation
stopped for every client. Bullet 2.78 (CoppeliaSim 4.1's default engine) applies no gyroscopic
force at all; MuJoCo's ``implicit`` keeps the body's spin as a rigid body keeps it. While no body
spins the scene steps with ``implicitfast`` (``simx:scene:integrator``, sim/integrator.py)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read

#: A joint's z axis along the body's y axis: a quarter turn about x.
_ALONG_Y = (math.cos(math.pi / 4), -math.sin(math.pi / 4), 0.0, 0.0)


def _bot(tmp_path):
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
    return xml


def _free_dof(w) -> int:
    return int(w.model.jnt_dofadr[next(j for j in range(w.model.njnt) if w.model.jnt_type[j] == 0)])


def test_a_falling_spinning_wheeled_body_keeps_its_spin(tmp_path):
    sim = Simulation(_bot(tmp_path), realtime=False)
    try:
        sim.start()
        w = sim.world
        dof = _free_dof(w)
        w.data.qvel[dof + 3:dof + 6] = [24.0, 0.1, -0.1]  # spinning about its long (x) axis, a little off
        w.changed()
        for _ in range(int(30.0 / w.dt)):
            w.step()  # raises PhysicsError once MuJoCo finds the NaN
            assert w.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICIT
        spin = w.data.qvel[dof + 3:dof + 6]
        assert spin[0] == pytest.approx(24.0, abs=1.0)
        assert np.hypot(spin[1], spin[2]) < 1.0  # implicitfast: 20 rad/s at 30 s, then a NaN
    finally:
        sim.stop()
        sim.close()


def test_implicitfast_while_no_body_spins_and_implicit_once_one_does(tmp_path):
    xml = _bot(tmp_path)
    assert '<text name="simx:scene:integrator" data="implicitfast_below=0.01"/>' in xml.read_text()
    sim = Simulation(xml, realtime=False)
    try:
        sim.start()
        w = sim.world
        assert w.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICIT  # as the MJCF says
        w.step()  # falling, wheels at 2 rad/s: 0.004 rad per 2 ms timestep
        assert w.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        w.data.qvel[_free_dof(w) + 4] = 5.5  # 0.011 rad per timestep about y
        w.changed()
        w.step()
        assert w.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICIT
        w.data.qvel[:] = 0.0
        w.changed()
        w.step()
        assert w.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        w.model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4  # a program's choice stays
        w.step()
        assert w.model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    finally:
        sim.stop()
        sim.close()


def test_without_the_text_the_scenes_integrator_stays(tmp_path):
    xml = _bot(tmp_path)
    xml.write_text(xml.read_text().replace('<text name="simx:scene:integrator" data="implicitfast_below=0.01"/>', ""))
    sim = Simulation(xml, realtime=False)
    try:
        sim.start()
        sim.world.step()
        assert sim.world.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICIT
    finally:
        sim.stop()
        sim.close()


@pytest.mark.parametrize("data, message", [("implicitfast_below=-1", "positive number"),
                                           ("below=0.01", "implicitfast_below= alone")])
def test_a_malformed_text_refuses_the_scene(tmp_path, data, message):
    xml = _bot(tmp_path)
    xml.write_text(xml.read_text().replace('data="implicitfast_below=0.01"', f'data="{data}"'))
    with pytest.raises(ValueError, match=message):
        Simulation(xml, realtime=False)
