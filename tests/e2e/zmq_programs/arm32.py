"""Issue 32's programs in CoppeliaSim 4.x style through the ZMQ remote API and the official
client, on tests/scenes/api32/arm.xml: a simIK pick-and-place of the 2-link arm's tip (pick
point, then place point, the motors following in stepping mode), a reach that stops on
sim.checkCollision / sim.checkDistance, and a line follower that reads an explicitly handled
vision sensor with sim.readVisionSensor and steers the camera onto the line.

Port from SIMX_ZMQ_PORT (default 23000). Prints one line per stage; exits non-zero when off.
"""

import math
import os

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')
simIK = client.require('simIK')

assert sim.getInt32Param(sim.intparam_program_version) >= 40300, 'needs CoppeliaSim 4.3+'
base, tip, target = sim.getObject('/base'), sim.getObject('/tip'), sim.getObject('/target')
link2, obstacle, eye = sim.getObject('/link2'), sim.getObject('/obstacle'), sim.getObject(':/eye')

env = simIK.createEnvironment()
group = simIK.createGroup(env)
simIK.setGroupCalculation(env, group, simIK.method_damped_least_squares, 0.05, 100)
# CoppeliaSim's groups ignore the joints' max step sizes by default: with damping 0.05 the reach's
# first steps would leap both joints to their upper limits, where simIK leaves them; bound them
simIK.setGroupFlags(env, group, simIK.group_enabled)
simIK.addElementFromScene(env, group, base, tip, target, simIK.constraint_x | simIK.constraint_y)

sim.setStepping(True)
sim.startSimulation()


def move_tip_to(x, y, max_steps=120):
    sim.setObjectPosition(target, -1, [x, y, 0])
    result, _, _ = simIK.handleGroup(env, group, {'syncWorlds': True})
    assert result == simIK.result_success, f'no IK solution for ({x}, {y})'
    for n in range(max_steps):
        sim.step()
        p = sim.getObjectPosition(tip, -1)
        if math.hypot(p[0] - x, p[1] - y) < 0.005:
            return n + 1
    raise SystemExit(f'tip did not reach ({x}, {y}): {p}')


# --- pick and place
print(f'pick reached in {move_tip_to(0.45, 0.35)} steps')
print(f'place reached in {move_tip_to(0.2, -0.5)} steps')

# --- a reach towards the obstacle that stops on contact or closeness
sim.setObjectPosition(target, -1, [0.35, 0.45, 0])
simIK.handleGroup(env, group, {'syncWorlds': True})
stopped = None
for n in range(200):
    sim.step()
    hit, _ = sim.checkCollision(link2, obstacle)
    _, data, _ = sim.checkDistance(link2, obstacle)
    if hit or data[6] < 0.02:
        joints = simIK.getGroupJoints(env, group)
        for j in joints:  # stop where it is
            sim.setJointTargetPosition(j, sim.getJointPosition(j))
        stopped = (n + 1, hit, data[6])
        break
assert stopped, 'the reach never came near the obstacle'
print(f'reach stopped after {stopped[0]} steps: collision {stopped[1]}, distance {stopped[2]:.3f} m')

# --- a line follower on an explicitly handled vision sensor
sim.setExplicitHandling(eye, 1)
pos = sim.getObjectPosition(eye, -1)
sim.setObjectPosition(eye, -1, [pos[0] + 0.12, pos[1], pos[2]])  # off the line
for n in range(40):
    sim.handleVisionSensor(eye)
    result, packet = sim.readVisionSensor(eye)
    img, (w, h) = sim.getVisionSensorImg(eye, 1)
    row = img[(h // 2) * w:(h // 2) * w + w]
    col = min(range(w), key=lambda x: row[x])
    error = col - (w - 1) / 2
    if abs(error) <= 1:
        break
    p = sim.getObjectPosition(eye, -1)
    sim.setObjectPosition(eye, -1, [p[0] + 0.01 * error, p[1], p[2]])  # steer towards the line
    sim.step()
assert abs(error) <= 1, f'line not centred: column {col} of {w}'
print(f'line centred after {n} corrections (average intensity {packet[10]:.2f})')

sim.stopSimulation()
print('OK arm32')
