"""CoppeliaSim 4.x's joint control modes (``sim.jointintparam_dynctrlmode``, simx_server/sim/dyn_ctrl.py)
and V-REP's cyclic joints (simx_server/sim/motors.py, simx_server/sim/joints.py), in process on a scene
of their own: a 1 kg cart on a slider and a wheel on an unlimited (cyclic) hinge, no gravity, no contacts.
The ZMQ and legacy doors reach the same parameter: tests/transport/test_zmq_api.py."""

from __future__ import annotations

import math

import pytest

from simx_wire.protocol import ArgumentError
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

SCENE = """<mujoco>
  <option gravity="0 0 0" timestep="0.005"/>
  <worldbody>
    <body name="Cart">
      <joint name="Slider" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.05 0.05 0.05" mass="1" contype="0" conaffinity="0"/>
    </body>
    <body name="Wheel" pos="0 1 0">
      <joint name="Rotor" type="hinge" axis="0 0 1"/>
      <geom type="cylinder" size="0.1 0.02" mass="1" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <custom><text name="simx:Slider" data="mode=passive{script}"/></custom>
</mujoco>
"""
MODE, MOTOR, LOOP, VMAX, KC_K, KC_C = 2039, 2000, 2001, 2017, 2018, 2019
FREE, FORCE, VELOCITY, POSITION, SPRING, CALLBACK = 0, 1, 4, 8, 12, 16


@pytest.fixture
def cell(tmp_path):
    """``(sim, api, slider, rotor)``: the scene started, a script's ``sim`` (the table Lua, Python,
    ZMQ and PyRep call)."""
    made = []

    def make(script: str | None = None):
        if script is not None:
            (tmp_path / "ctl.lua").write_text(script)
        (tmp_path / "cell.xml").write_text(SCENE.format(script=" child_script=ctl.lua" if script else ""))
        sim = Simulation(tmp_path / "cell.xml", realtime=False)
        made.append(sim)
        w = sim.world
        api = script_sim(w, w.resolve("Cart").handle, sim.signals, simulation=sim)
        sim.start()
        return sim, api, w.resolve("Slider").handle, w.resolve("Rotor").handle

    yield make
    for sim in made:
        sim.stop()
        sim.close()


def run(sim, seconds: float) -> None:
    for _ in range(round(seconds / sim.world.dt)):
        sim.step()


def test_force_mode_applies_the_signed_target_force(cell):
    sim, api, slider, _ = cell()
    assert api.getObjectInt32Param(slider, MODE) == FREE  # the scene's passive joint
    api.setObjectInt32Param(slider, MODE, FORCE)
    api.setJointTargetForce(slider, 2.0)
    # CoppeliaSim 4.x reads the legacy flags from the mode; the change set a high target velocity
    assert [api.getObjectInt32Param(slider, p) for p in (MODE, MOTOR, LOOP)] == [FORCE, 1, 0]
    assert api.getJointTargetVelocity(slider) == 1000.0 and api.getJointTargetForce(slider) == 2.0
    run(sim, 1.0)  # 2 N on 1 kg for 1 s, nothing else: no gravity compensation, no velocity servo
    assert api.getJointVelocity(slider) == pytest.approx(2.0, abs=1e-3)
    assert api.getJointPosition(slider) == pytest.approx(1.0, abs=0.01)
    assert api.getJointForce(slider) == pytest.approx(2.0, abs=1e-6)
    # a negative signed force turns the target velocity round (CJoint::setTargetForce) and brakes
    api.setJointTargetForce(slider, -2.0)
    assert api.getJointTargetForce(slider) == -2.0 and api.getJointTargetVelocity(slider) == -1000.0
    run(sim, 1.0)
    assert api.getJointVelocity(slider) == pytest.approx(0.0, abs=1e-3)
    # unsigned: a negative value is 0; a positive one takes the target velocity's sign
    api.setJointTargetForce(slider, 3.0, False)
    assert api.getJointTargetForce(slider) == -3.0
    api.setJointTargetVelocity(slider, 5.0)  # ... and a target velocity turns the force round
    assert api.getJointTargetForce(slider) == 3.0


def test_free_velocity_position_modes_and_the_legacy_flags(cell):
    sim, api, slider, _ = cell()
    api.setObjectInt32Param(slider, MODE, VELOCITY)
    # CJoint::setDynCtrlMode: velocity mode starts at 0.1 m/s on a prismatic joint
    assert api.getJointTargetVelocity(slider) == pytest.approx(0.1)
    api.setJointTargetForce(slider, 50.0)
    api.setJointTargetVelocity(slider, 0.4)
    run(sim, 0.5)
    assert api.getJointVelocity(slider) == pytest.approx(0.4, abs=0.01)
    api.setObjectInt32Param(slider, MODE, FREE)  # motor off: the cart coasts
    assert [api.getObjectInt32Param(slider, p) for p in (MODE, MOTOR)] == [FREE, 0]
    x0 = api.getJointPosition(slider)
    run(sim, 0.5)
    assert api.getJointPosition(slider) - x0 == pytest.approx(0.2, abs=0.01)
    api.setObjectInt32Param(slider, MODE, POSITION)
    assert [api.getObjectInt32Param(slider, p) for p in (MODE, MOTOR, LOOP)] == [POSITION, 1, 1]
    api.setJointTargetPosition(slider, 0.0)
    run(sim, 3.0)
    assert api.getJointPosition(slider) == pytest.approx(0.0, abs=0.01)
    # the legacy flags change the mode as CoppeliaSim 4.x's simSetObjectInt32Param does
    api.setObjectInt32Param(slider, MODE, FORCE)
    api.setObjectInt32Param(slider, LOOP, 1)
    assert api.getObjectInt32Param(slider, MODE) == POSITION
    api.setObjectInt32Param(slider, MODE, CALLBACK)
    api.setObjectInt32Param(slider, LOOP, 0)
    assert api.getObjectInt32Param(slider, MODE) == VELOCITY
    with pytest.raises(ArgumentError, match="not a joint control mode"):
        api.setObjectInt32Param(slider, MODE, 3)
    sim.stop()  # a stop gives the joint the mode it started with (CJoint::simulationEnded)
    assert api.getObjectInt32Param(slider, MODE) == FREE


def test_spring_mode_is_k_e_plus_c_de_dt_about_the_target(cell):
    sim, api, slider, _ = cell()
    assert api.getObjectFloatParam(slider, KC_K) == pytest.approx(0.1)  # CoppeliaSim's defaults
    assert api.getObjectFloatParam(slider, KC_C) == 0.0
    api.setObjectInt32Param(slider, MODE, SPRING)
    api.setObjectFloatParam(slider, KC_K, 4.0)  # 1 kg on 4 N/m: a period of pi s
    api.setJointTargetForce(slider, 100.0)
    api.setJointTargetPosition(slider, 0.1)
    assert api.getObjectInt32Param(slider, MODE) == SPRING and api.getJointTargetVelocity(slider) == 1000.0
    run(sim, math.pi / 2)  # half a period: from 0 to the far side, 0.2
    assert api.getJointPosition(slider) == pytest.approx(0.2, abs=0.01)
    api.setObjectFloatParam(slider, KC_C, 8.0)  # overdamped: it creeps to the target and stays
    run(sim, 6.0)
    assert api.getJointPosition(slider) == pytest.approx(0.1, abs=0.005)


CALLBACK_SCRIPT = """
function sysCall_init()
    sim.setObjectInt32Param(sim.getObject('/Slider'), sim.jointintparam_dynctrlmode, sim.jointdynctrl_callback)
end
function sysCall_joint(inData)
    sim.setFloatSignal('error', inData.error)
    sim.setInt32Signal('mode', inData.mode)
    if inData.pos < 0.5 then return {force = 1.5} end
    return {vel = 0, force = 20}
end
"""


def test_callback_mode_runs_the_scripts_sysCall_joint(cell):
    sim, api, slider, _ = cell(CALLBACK_SCRIPT)
    assert api.getObjectInt32Param(slider, MODE) == CALLBACK
    api.setJointTargetPosition(slider, 0.3)
    run(sim, 0.5)  # 1.5 N alone: force control
    assert api.getJointVelocity(slider) == pytest.approx(0.75, abs=0.01)
    assert sim.signals.get_float("error") == pytest.approx(0.3 - api.getJointPosition(slider), abs=0.01)
    assert sim.signals.get_int("mode") == 5  # sim.jointmode_dynamic
    run(sim, 1.0)  # past 0.5 m: a velocity of 0 with 20 N stops it there
    assert api.getJointVelocity(slider) == pytest.approx(0.0, abs=1e-3)
    assert api.getJointPosition(slider) == pytest.approx(0.5, abs=0.05)


def test_cyclic_joint_position_control_takes_the_shortest_way(cell):
    # A target far beyond a turn (a program's accumulated angle): V-REP's controller takes the
    # error modulo 2 pi (simDyn's getAngleMinusAlpha), and keeps the target in [-pi, pi]
    # (CJoint::setTargetPosition); the long way was 2052 rad at 1 rad/s, for half an hour.
    sim, api, _, rotor = cell()
    api.setObjectInt32Param(rotor, MODE, POSITION)
    api.setObjectFloatParam(rotor, VMAX, 1.0)
    api.setJointTargetPosition(rotor, 2052.0)
    want = math.remainder(2052.0, 2 * math.pi)  # -2.60 rad: backwards is shorter
    assert api.getJointTargetPosition(rotor) == pytest.approx(want)
    sim.step()
    assert api.getJointVelocity(rotor) < -0.9
    run(sim, 4.0)
    assert api.getJointPosition(rotor) == pytest.approx(want, abs=0.01)


def test_a_cyclic_joint_reads_within_minus_pi_pi_however_far_it_turned(cell):
    sim, api, _, rotor = cell()
    api.setObjectInt32Param(rotor, MODE, VELOCITY)
    api.setJointTargetVelocity(rotor, 5.0)
    readings = []
    for _ in range(40):  # 2 s at 5 rad/s: more than a turn and a half
        sim.step()
        readings.append(api.getJointPosition(rotor))
    assert all(-math.pi <= q <= math.pi for q in readings)
    assert min(readings) < -2.5 and max(readings) > 2.5  # it went round
    assert api.getJointPosition(rotor) == pytest.approx(math.remainder(10.0, 2 * math.pi), abs=0.05)
