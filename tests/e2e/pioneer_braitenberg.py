"""A Pioneer P3-DX Braitenberg program as V-REP's mobile-robot tutorials write it (a test
program of simx's own): 16 sonars read with streaming then buffer, the two wheel velocities
streamed in a loop with no sleep, for a span of simulated time. It also streams the robot's
position and three collision objects (the robot's parts against the room) and prints one JSON
line: how far it drove, the closest sonar reading, how many loop turns saw an obstacle and how
many simulation steps it was touching the room.

    python pioneer_braitenberg.py PORT SECONDS
"""

import json
import math
import sys

import vrep

port, seconds = int(sys.argv[1]), float(sys.argv[2])
vrep.simxFinish(-1)
cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
if cid == -1:
    sys.exit("no connection")

wait = vrep.simx_opmode_oneshot_wait
sensors = [vrep.simxGetObjectHandle(cid, "Pioneer_p3dx_ultrasonicSensor%d" % (i + 1), wait)[1] for i in range(16)]
left = vrep.simxGetObjectHandle(cid, "Pioneer_p3dx_leftMotor", wait)[1]
right = vrep.simxGetObjectHandle(cid, "Pioneer_p3dx_rightMotor", wait)[1]
robot = vrep.simxGetObjectHandle(cid, "Pioneer_p3dx", wait)[1]
collisions = [vrep.simxGetCollisionHandle(cid, name, wait)[1]
              for name in ("Pioneer_room", "leftWheel_room", "rightWheel_room")]
if -1 in sensors or min(left, right, robot, *collisions) < 0:
    sys.exit("missing objects")

for s in sensors:
    vrep.simxReadProximitySensor(cid, s, vrep.simx_opmode_streaming)
for c in collisions:
    vrep.simxReadCollision(cid, c, vrep.simx_opmode_streaming)
vrep.simxGetObjectPosition(cid, robot, -1, vrep.simx_opmode_streaming)

noDetectionDist = 0.5
maxDetectionDist = 0.2
braitenbergL = [-0.2, -0.4, -0.6, -0.8, -1, -1.2, -1.4, -1.6, 0, 0, 0, 0, 0, 0, 0, 0]
braitenbergR = [-1.6, -1.4, -1.2, -1, -0.8, -0.6, -0.4, -0.2, 0, 0, 0, 0, 0, 0, 0, 0]
v0 = 2

vrep.simxGetPingTime(cid)
start = vrep.simxGetLastCmdTime(cid) / 1000.0
last_time, last_pos = start, None
travelled, closest, seen, touching = 0.0, float("inf"), 0, 0
while True:
    detect = [0.0] * 16
    for i, s in enumerate(sensors):
        rc, state, point, _, _ = vrep.simxReadProximitySensor(cid, s, vrep.simx_opmode_buffer)
        dist = math.sqrt(sum(x * x for x in point))
        if rc == vrep.simx_return_ok and state and dist < noDetectionDist:
            closest = min(closest, dist)
            detect[i] = 1 - (max(dist, maxDetectionDist) - maxDetectionDist) / (noDetectionDist - maxDetectionDist)
    seen += any(detect)
    vLeft = v0 + sum(b * d for b, d in zip(braitenbergL, detect))
    vRight = v0 + sum(b * d for b, d in zip(braitenbergR, detect))
    vrep.simxSetJointTargetVelocity(cid, left, vLeft, vrep.simx_opmode_streaming)
    vrep.simxSetJointTargetVelocity(cid, right, vRight, vrep.simx_opmode_streaming)

    now = vrep.simxGetLastCmdTime(cid) / 1000.0  # the simulation time of the newest stream update
    if now != last_time:  # a new step: its collision states and position
        last_time = now
        touching += any(vrep.simxReadCollision(cid, c, vrep.simx_opmode_buffer)[1] for c in collisions)
        rc, pos = vrep.simxGetObjectPosition(cid, robot, -1, vrep.simx_opmode_buffer)
        if rc == vrep.simx_return_ok:
            if last_pos is not None:
                travelled += math.dist(pos[:2], last_pos[:2])
            last_pos = pos
    if now - start >= seconds:
        break

vrep.simxSetJointTargetVelocity(cid, left, 0, vrep.simx_opmode_oneshot)
vrep.simxSetJointTargetVelocity(cid, right, 0, vrep.simx_opmode_oneshot)
vrep.simxGetPingTime(cid)
vrep.simxFinish(cid)
print(json.dumps({"simulated_s": round(last_time - start, 2), "travelled_m": round(travelled, 3),
                  "closest_m": round(closest, 3), "loops_with_obstacle": seen, "steps_touching": touching,
                  "final_position": last_pos}))
