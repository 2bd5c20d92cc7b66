-- V-REP 3.2's threaded BubbleRob script (the tutorial's, with signals a test reads):
-- drive ahead; when the nose sensor sees something, back up turning for 2 s.
bubbleRobBase=simGetObjectAssociatedWithScript(sim_handle_self)
leftMotor=simGetObjectHandle("bubbleRob_leftMotor")
rightMotor=simGetObjectHandle("bubbleRob_rightMotor")
noseSensor=simGetObjectHandle("bubbleRob_sensingNose")
speed=4 -- rad/s
backUntilTime=-1
detections=0
simSetThreadAutomaticSwitch(false)
while (simGetSimulationState()~=sim_simulation_advancing_abouttostop) do
    local result=simReadProximitySensor(noseSensor)
    if (result>0) then
        if backUntilTime<simGetSimulationTime() then detections=detections+1 end
        backUntilTime=simGetSimulationTime()+2
    end
    if (backUntilTime<simGetSimulationTime()) then
        simSetJointTargetVelocity(leftMotor,speed)
        simSetJointTargetVelocity(rightMotor,speed)
        simSetIntegerSignal("backing",0)
    else
        simSetJointTargetVelocity(leftMotor,-speed/2)
        simSetJointTargetVelocity(rightMotor,-speed/8)
        simSetIntegerSignal("backing",1)
    end
    simSetIntegerSignal("detections",detections)
    simSwitchThread()
end
