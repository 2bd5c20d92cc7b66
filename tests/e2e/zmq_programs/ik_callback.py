"""A tip moved through IK by a dummy that CoppeliaSim 4.3-4.5's positional sim.moveToPose and a
callback move, in the style of CoppeliaSim's ZMQ remote API example
sendIkMovementSequence-simMoveToPose.py: the scene (messaging/ikMovementViaRemoteApi.ttt, simx's
MJCF stand-in) is already loaded; its arm's child script solves IK every step so that '/LBR4p/tip'
follows '/LBR4p/target'; the client's callback places the target (4.3's argument order
sim.setObjectPose(handle, -1, pose)); the motion runs along a straight line (a metric).

Port: SIMX_ZMQ_PORT (default 23000). Exits non-zero on failure.
"""

import math
import os

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')
tip, target = sim.getObject('/LBR4p/tip'), sim.getObject('/LBR4p/target')
placed = []


def place(pose, vel, accel, handle):
    placed.append(pose)
    sim.setObjectPose(handle, -1, pose)


def angle_between(q1, q2):
    dot = abs(sum(a * b for a, b in zip(q1, q2)))
    return 2 * math.acos(min(1.0, dot))


# stepped by this client (as arm_callback.py): the simulation advances only inside the motions and
# waits, so the steps counted between two reads of the time are the motion's own
sim.setStepping(True)
sim.startSimulation()
start = sim.getObjectPose(tip, -1)
half = math.sqrt(0.5)
goals = [[0.05, -0.05, 0.85, 0, 0, 0, 1], [0.05, -0.05, 0.85, -half, 0, 0, -half], start]
dt = sim.getSimulationTimeStep()
for n, goal in enumerate(goals, 1):
    del placed[:]
    t0 = sim.getSimulationTime()
    end, time_left = sim.moveToPose(-1, sim.getObjectPose(tip, -1), [0.3], [0.2], [80], goal, place, target,
                                    [1, 1, 1, 0.1])
    steps = round((sim.getSimulationTime() - t0) / dt)
    assert abs(len(placed) - steps) <= 1, (len(placed), steps)
    assert max(abs(a - b) for a, b in zip(end[:3], goal[:3])) < 1e-6 and angle_between(end[3:], goal[3:]) < 1e-6
    sim.wait(0.5)  # the arm's motors settle on the last IK solution
    pose = sim.getObjectPose(tip, -1)
    off = math.dist(pose[:3], goal[:3])
    turn = math.degrees(angle_between(pose[3:], goal[3:]))
    print(f'pose {n}: {len(placed)} callbacks in {steps} steps, tip within {1000 * off:.1f} mm and {turn:.2f} deg')
    assert off < 0.005 and turn < 1, pose
sim.stopSimulation()
print('OK ik_callback')
