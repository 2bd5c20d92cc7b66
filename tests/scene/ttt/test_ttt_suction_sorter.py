"""A suction-cup sorter of V-REP's factory cells, on a scene of the project's own (a synthetic
V-REP 3.6 .ttt): a carrier moved by a threaded script takes a suction pad of V-REP's model
library (its proximity sensor, a force sensor ``suctionPadLink`` carrying loop-closure dummy 2,
loop-closure dummy 1, and the pad's child script with its ``active``, ``infiniteStrength`` and
force limits) over three balls in turn, lowers it, activates it, lifts, carries the ball to
the drop zone and releases it: all three balls are lifted and placed, and the force sensor
under the pad's second dummy reads the held ball's weight, as CoppeliaSim's engines make that
dummy link the sensor's constraint.
"""

from __future__ import annotations

import logging
import math

import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read

# V-REP's suction pad script (its model library's pattern, 3.6 callbacks): inactive, loop-closure
# dummy 1 sits on dummy 2 on the pad; active and free, it goes onto the first respondable shape
# its sensor detects and is linked to dummy 2; attached and not infinitely strong, the link breaks
# when the force sensor under dummy 2 reads more than the pull, shear or peel limits.
PAD_LUA = """function sysCall_init()
    s=sim.getObjectHandle('suctionPadSensor')
    l=sim.getObjectHandle('suctionPadLoopClosureDummy1')
    l2=sim.getObjectHandle('suctionPadLoopClosureDummy2')
    b=sim.getObjectHandle('suctionPad')
    link=sim.getObjectHandle('suctionPadLink')
    infiniteStrength=sim.getScriptSimulationParameter(sim.handle_self,'infiniteStrength')
    maxPullForce=sim.getScriptSimulationParameter(sim.handle_self,'maxPullForce')
    maxShearForce=sim.getScriptSimulationParameter(sim.handle_self,'maxShearForce')
    maxPeelTorque=sim.getScriptSimulationParameter(sim.handle_self,'maxPeelTorque')
    sim.setLinkDummy(l,-1)
    sim.setObjectParent(l,b,true)
    sim.setObjectMatrix(l,-1,sim.getObjectMatrix(l2,-1))
    breaks=0
end
function detach()
    sim.setLinkDummy(l,-1)
    sim.setObjectParent(l,b,true)
    sim.setObjectMatrix(l,-1,sim.getObjectMatrix(l2,-1))
end
function sysCall_sensing()
    local parent=sim.getObjectParent(l)
    if sim.getScriptSimulationParameter(sim.handle_self,'active')==false then
        if parent~=b then detach() end
    elseif parent==b then
        local index=0
        while true do
            local shape=sim.getObjects(index,sim.object_shape_type)
            if shape==-1 then break end
            if shape~=b and sim.getObjectInt32Parameter(shape,sim.shapeintparam_respondable)~=0
               and sim.checkProximitySensor(s,shape)==1 then
                detach()
                sim.setObjectParent(l,shape,true)
                sim.setLinkDummy(l,l2)
                break
            end
            index=index+1
        end
    else
        local result,force,torque=sim.readForceSensor(link)
        held={result,force[1],force[2],force[3]}
        if result>0 and not infiniteStrength then
            local shear=math.sqrt(force[1]*force[1]+force[2]*force[2])
            if force[3]>maxPullForce or shear>maxShearForce or torque[1]>maxPeelTorque or torque[2]>maxPeelTorque then
                detach()
                breaks=breaks+1
            end
        end
    end
end
function status()
    return {breaks,sim.getObjectParent(l)},held,{},''
end
"""
# The sorter: a V-REP 3.6 threaded script that moves the carrier at 0.2 m/s (a setObjectPosition
# per step) and switches the pad through its script's 'active' parameter.
SORTER_LUA = """function moveTo(target)
    local p=sim.getObjectPosition(carrier,-1)
    local d={target[1]-p[1],target[2]-p[2],target[3]-p[3]}
    local n=math.ceil(math.sqrt(d[1]*d[1]+d[2]*d[2]+d[3]*d[3])/0.01)
    for i=1,n do
        sim.setObjectPosition(carrier,-1,{p[1]+d[1]*i/n,p[2]+d[2]*i/n,p[3]+d[3]*i/n})
        sim.switchThread()
    end
end
function setActive(on)
    sim.setScriptSimulationParameter(pad,'active',on and 'true' or 'false')
end
function sysCall_threadmain()
    carrier=sim.getObjectHandle('Carrier')
    pad=sim.getScriptAssociatedWithObject(sim.getObjectHandle('suctionPad'))
    sim.setThreadAutomaticSwitch(false)
    for i=0,2 do
        local ball=sim.getObjectHandle('Ball'..i)
        local b=sim.getObjectPosition(ball,-1)
        moveTo({b[1],b[2],0.3})
        moveTo({b[1],b[2],REACH})
        setActive(true)
        sim.wait(0.5)
        moveTo({b[1],b[2],0.3})
        moveTo({-0.3,-0.1+0.1*i,0.3})
        moveTo({-0.3,-0.1+0.1*i,0.12})
        setActive(false)
        sim.wait(0.5)
        moveTo({-0.3,-0.1+0.1*i,0.3})
    end
    sim.setIntegerSignal('sorted',1)
end
"""
RADIUS = 0.025
DOWN = (0, 1, 0, 0)  # w x y z: 180 deg about x, the sensor's +z downward


def _scene(path):
    # the carrier's origin is 0.0555 m above the pad's bottom face: lowered to REACH it rests
    # its pad on the ball's top
    reach = 2 * RADIUS + 0.0555
    body = W.cuboid_shape(1, -1, "Floor", (3, 3, 0.1), (0, 0, -0.05), dynamic=False)
    for i in range(3):
        body += W.cuboid_shape(10 + i, -1, f"Ball{i}", (2 * RADIUS,) * 3, (0.3 + 0.12 * i, 0.05 * (i - 1), RADIUS),
                               mass=0.05, primitive=4)
    body += (W.cuboid_shape(2, -1, "Carrier", (0.04, 0.04, 0.04), (0.3, 0, 0.3), dynamic=False, respondable=False)
             + W.force_sensor(3, 2, "suctionPadConnection", (0, 0, -0.03))
             + W.cuboid_shape(4, 3, "suctionPad", (0.03, 0.03, 0.02), (0, 0, -0.0155), mass=0.05, primitive=5)
             + W.rec("SNR", W.common(5, 4, "suctionPadSensor", (0, 0, -0.0101), DOWN)
                     + W.lst(W.rec("Snt", W.i32(34)), W.rec("Vod", W.lst(W.rec("Ss3", W.f32(0, 0.02, *([0.0] * 7)))))))
             + W.force_sensor(6, 4, "suctionPadLink", (0, 0, -0.0101))
             + W.dummy(7, 6, "suctionPadLoopClosureDummy2")
             + W.dummy(8, 4, "suctionPadLoopClosureDummy1", (0, 0, -0.0101)))
    body += (W.script(100, 4, PAD_LUA, parameters=(("active", "", "false"), ("infiniteStrength", "", "false"),
                                                     ("maxPullForce", "N", "3"), ("maxShearForce", "N", "1"),
                                                     ("maxPeelTorque", "Nm", "0.1")))
             + W.script(101, 2, SORTER_LUA.replace("REACH", repr(reach)), threaded=True))
    f = path / "sorter.ttt"
    f.write_bytes(W.ttt_file(W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + body, program=30600))
    xml, _ = convert.convert(reader.read(f), path / "out", "sorter")
    return xml


def test_a_suction_sorter_lifts_and_places_all_three_balls(tmp_path, caplog):
    sim = Simulation(_scene(tmp_path), realtime=False)
    world = sim.world
    balls = [world.resolve(f"Ball{i}").handle for i in range(3)]
    highest = [0.0] * 3
    try:
        with caplog.at_level(logging.WARNING, "simx"):
            sim.start()
            for _ in range(1200):  # at most 60 s
                sim.step()
                for i, b in enumerate(balls):
                    highest[i] = max(highest[i], world.position(b, -1)[2])
                if sim.signals.get("int", "sorted") is not None:
                    break
            (breaks, holder), held = sim.scripts.call("suctionPad", 1, "status", [], [], [], b"")[:2]
            placed = [world.position(b, -1) for b in balls]
        assert sim.signals.get("int", "sorted") == 1
        assert highest == [pytest.approx(0.3 - 0.0555 - RADIUS, abs=0.01)] * 3, highest  # each hung under the pad
        for i, p in enumerate(placed):
            assert (p[0], p[1], p[2]) == pytest.approx((-0.3, -0.1 + 0.1 * i, RADIUS), abs=0.02), (i, p)
        assert breaks == 0 and holder == world.resolve("suctionPad").handle
        # the link's force sensor carried the last ball (its weight along gravity, its z up), and
        # read it (state 1): the pad's break test has its values
        assert held == [1, pytest.approx(0, abs=0.02), pytest.approx(0, abs=0.02), pytest.approx(-0.05 * 9.81, abs=0.03)]
    finally:
        sim.stop()
        sim.close()
    assert math.isfinite(highest[0])
