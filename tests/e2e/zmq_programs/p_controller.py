"""A P controller closed by the client, in the style of CoppeliaSim's ZMQ remote API example
pController.py: the scene is loaded by its CoppeliaSim name (a .ttt under
sim.stringparam_scenedefaultdir, which simx maps to its MJCF stand-in), the joint found as
'/Cuboid[0]/joint', stepping mode, one velocity command per step.

Port: SIMX_ZMQ_PORT (default 23000). Prints each angle reached; exits non-zero on failure.
"""

import math
import os

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')

scene_dir = sim.getStringParam(sim.stringparam_scenedefaultdir)
sim.loadScene(scene_dir + '/messaging/pControllerViaRemoteApi.ttt')
joint = sim.getObject('/Cuboid[0]/joint')
assert sim.getObjectType(joint) == sim.object_joint_type

GAIN = 0.1          # of the error, per 5 ms
MAX_SPEED = 2 * math.pi


def command(angle, target):
    error = math.atan2(math.sin(target - angle), math.cos(target - angle))
    return max(-MAX_SPEED, min(MAX_SPEED, error * GAIN / 0.005))


def go_to(target, max_steps=100):
    angle = sim.getJointPosition(joint)
    steps = 0
    while abs(angle - target) > math.radians(0.1):
        sim.setJointTargetVelocity(joint, command(angle, target))
        sim.setJointTargetForce(joint, 100, False)
        sim.step()
        steps += 1
        if steps > max_steps:
            raise SystemExit(f'{math.degrees(target):.0f} deg not reached in {max_steps} steps: at {math.degrees(angle):.2f}')
        angle = sim.getJointPosition(joint)
    print(f'{math.degrees(target):6.1f} deg reached in {steps:2d} steps (at {math.degrees(angle):.3f})')


sim.setStepping(True)
sim.startSimulation()
for degrees in (45, 90, -89, 0):
    go_to(math.radians(degrees))
sim.stopSimulation()
print('OK p_controller')
