"""Robots moved by jerk-limited motions from threads of their own, each with its own client in
stepping mode, in the style of CoppeliaSim's ZMQ remote API example simpleMovement.py:
sim.moveToConfig for two arms whose joints share the alias 'joint', sim.moveToPose for a dummy.

Port: SIMX_ZMQ_PORT (default 23000). Exits non-zero on failure.
"""

import math
import os
import threading

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

PORT = int(os.environ.get('SIMX_ZMQ_PORT', '23000'))
results = {}


def arm(color, accel):
    sim = RemoteAPIClient('localhost', PORT).require('sim')
    sim.setStepping(True)
    joints = [sim.getObject(f'/{color}Robot/joint', {'index': i}) for i in range(7)]
    goal = [math.radians(a) for a in (90, 90, 170, -90, 90, 90, 0)]
    vel, acc = math.radians(110), math.radians(accel)
    t0 = sim.getSimulationTime()
    out = sim.moveToConfig({'joints': joints, 'targetPos': goal, 'maxVel': [vel] * 7,
                            'maxAccel': [acc] * 7, 'maxJerk': [math.radians(3 * accel)] * 7})
    reached = [sim.getJointPosition(j) for j in joints]
    results[color] = (sim.getSimulationTime() - t0, max(abs(a - b) for a, b in zip(reached, goal)), out['pos'])
    sim.moveToConfig({'joints': joints, 'targetPos': [0] * 7, 'maxVel': [vel] * 7, 'maxAccel': [acc] * 7,
                      'maxJerk': [math.radians(3 * accel)] * 7})
    sim.setStepping(False)


def dummy():
    sim = RemoteAPIClient('localhost', PORT).require('sim')
    sim.setStepping(True)
    target = sim.getObject('/greenRobot/target')
    start = sim.getObjectPose(target)
    up = list(start)
    up[2] += 0.2
    sim.moveToPose({'object': target, 'targetPose': up, 'maxVel': [0.5] * 4, 'maxAccel': [0.1, 0.1, 0.1, 1],
                    'maxJerk': [3] * 4})
    high = sim.getObjectPose(target)
    turned = sim.rotateAroundAxis(high, [1, 0, 0], high[:3], math.pi / 2)
    sim.moveToPose({'object': target, 'targetPose': turned, 'maxVel': [0.5] * 4, 'maxAccel': [0.1, 0.1, 0.1, 1],
                    'maxJerk': [3] * 4})
    results['green'] = (high[2] - start[2], sim.getObjectPose(target))
    sim.setStepping(False)


client = RemoteAPIClient('localhost', PORT)
sim = client.require('sim')
sim.loadScene(sim.getStringParam(sim.stringparam_scenedefaultdir) + '/messaging/movementViaRemoteApi.ttt')
sim.startSimulation()
threads = [threading.Thread(target=arm, args=('blue', 40)), threading.Thread(target=arm, args=('red', 100)),
           threading.Thread(target=dummy)]
for t in threads:
    t.start()
for t in threads:
    t.join()
sim.stopSimulation()

for color in ('blue', 'red'):
    took, error, _ = results[color]
    print(f'{color}Robot: its configuration reached in {took:.2f} s of simulation, within {math.degrees(error):.2f} deg')
    assert error < math.radians(1)
assert results['red'][0] < results['blue'][0], 'the arm allowed more acceleration is there first'
rise, pose = results['green']
print(f'target: raised by {rise:.3f} m, then turned to quaternion {[round(v, 3) for v in pose[3:]]}')
assert abs(rise - 0.2) < 1e-3 and abs(abs(pose[3]) - math.sin(math.pi / 4)) < 1e-3
print('OK movement')
