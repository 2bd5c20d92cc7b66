"""A CoppeliaSim 4.x manipulation program on simx's bundled UR5 scene, through the ZMQ remote API
and the official client (coppeliasim-zmqremoteapi-client), written as such programs are: stepping
mode, joint targets, the Kinect's image as a NumPy array from bytes, the gripper's child script.

Run against ``simx-server --stopped --zmq-port PORT`` (the bundled scene); the port comes from
SIMX_ZMQ_PORT (default 23000, CoppeliaSim's). With SIMX_SAVE_DIR set, the camera image is saved
there as kinect.png. Prints one line per stage; exits non-zero when something is off.
"""

import math
import os

import numpy as np
from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')

joints = [sim.getObject(f'/UR5/UR5_joint{i}') for i in range(1, 7)]
rgb = sim.getObject('/UR5/kinect_rgb')
depth_sensor = sim.getObject('/UR5/kinect_depth')
fingers = sim.getObject('/UR5/RG2/RG2_openCloseJoint')
gripper = client.getScriptFunctions(sim.getScript(sim.scripttype_childscript, sim.getObject('/UR5/RG2')))


def step_until(done, max_steps):
    """Step the simulation until done() or max_steps; the number of steps taken."""
    for n in range(1, max_steps + 1):
        sim.step()
        if done():
            return n
    raise SystemExit(f'not reached within {max_steps} steps')


sim.setStepping(True)
sim.startSimulation()
dt = sim.getSimulationTimeStep()

# 1. Move the arm over the table, joint targets in rad.
pose = [math.pi / 3, 0.5, 0.0, 1.07, -math.pi / 2, 0.0]  # the Kinect above the table, looking down
for joint, q in zip(joints, pose):
    sim.setJointTargetPosition(joint, q)
steps = step_until(lambda: max(abs(sim.getJointPosition(j) - q) for j, q in zip(joints, pose)) < 0.01, 200)
t = sim.getSimulationTime()
print(f'arm reached its pose in {steps} steps, t = {t:.2f} s')
assert abs(t - steps * dt) < 1e-6, 'one step per sim.step() in stepping mode'

# 2. The Kinect's colour image and depth buffer, as CoppeliaSim gives them: bytes, rows bottom-up.
img, (width, height) = sim.getVisionSensorImg(rgb)
frame = np.frombuffer(img, dtype=np.uint8).reshape(height, width, 3)[::-1]
assert frame.shape == (480, 640, 3) and frame.std() > 5, 'a real picture, not a blank one'
red = (frame[:, :, 0] > 150) & (frame[:, :, 1] < 80) & (frame[:, :, 2] < 80)
rows, cols = np.nonzero(red)
assert red.sum() > 500, 'the red ball on the table is in view'
print(f'the ball covers {red.sum()} pixels around ({cols.mean():.0f}, {rows.mean():.0f})')
if os.environ.get('SIMX_SAVE_DIR'):
    import cv2
    cv2.imwrite(os.path.join(os.environ['SIMX_SAVE_DIR'], 'kinect.png'), frame[:, :, ::-1])
buf, (dw, dh) = sim.getVisionSensorDepth(depth_sensor, 1)  # options bit 0: metres
depth = np.frombuffer(buf, dtype=np.float32).reshape(dh, dw)
print(f'image {width}x{height}, mean colour {frame.reshape(-1, 3).mean(axis=0).round(1).tolist()}, '
      f'depth {depth.min():.3f}..{depth.max():.3f} m')
assert 0.01 <= depth.min() < depth.max() <= 3.5

# 3. The gripper, through its child script: rg2Close by name@object (CoppeliaSim 4.0-4.5), then
#    rg2Open through the script's functions (4.6+).
opened = sim.getJointPosition(fingers)
ret = sim.callScriptFunction('rg2Close@/UR5/RG2', sim.scripttype_childscript)
print('rg2Close answered', ret)
step_until(lambda: sim.getJointPosition(fingers) < opened - 0.02, 100)
closed = sim.getJointPosition(fingers)
ret = gripper.rg2Open()
step_until(lambda: sim.getJointPosition(fingers) > closed + 0.02, 100)
print(f'fingers {opened:.4f} -> {closed:.4f} -> {sim.getJointPosition(fingers):.4f} m')

sim.stopSimulation()
assert sim.getSimulationState() == sim.simulation_stopped
sim.setStepping(False)
print('OK ur5_pick')
