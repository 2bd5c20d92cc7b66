"""An IK arm's target moved by the scene's threaded child script, driven through script functions
and a string signal, in the style of CoppeliaSim 4.3-4.5's ZMQ remote API examples
sendIkMovementSequence-mov.py and -pts.py: the scene (messaging/ikMovementViaRemoteApi.ttt,
simx's MJCF stand-in) is already loaded; '/LBR4p''s script answers its target's pose and the
joints with 'remoteApi_getPoseAndConfig', takes movement data with
'remoteApi_movementDataFunction', executes an id with 'remoteApi_executeMovement' and says which
id it executed in the string signal '/LBR4p_executedMovId'; its IK makes the tip follow the
target. This program steps the simulation itself (stepping mode) and watches every step.

Port: SIMX_ZMQ_PORT (default 23000). Exits non-zero on failure.
"""

import math
import os

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')
arm = '/LBR4p'
tip, target = sim.getObject(arm + '/tip'), sim.getObject(arm + '/target')
seen = []  # the signal's values, one entry per change


def watch():
    sim.step()
    s = sim.getStringSignal(arm + '_executedMovId')
    if not seen or seen[-1] != s:
        seen.append(s)


def step_until(id_, limit=300):
    for _ in range(limit):
        if seen and seen[-1] == id_:
            return
        watch()
    raise AssertionError(f'{id_!r} not executed in {limit} steps; the signal said {seen}')


def call(func, *args):
    return sim.callScriptFunction(func + '@' + arm, sim.scripttype_childscript, *args)


def turn(q1, q2):
    return math.degrees(2 * math.acos(min(1.0, abs(sum(a * b for a, b in zip(q1, q2))))))


def mov(id_, pose):
    return {'id': id_, 'type': 'mov', 'targetPose': pose, 'maxVel': 0.4, 'maxAccel': 2.0, 'maxJerk': 30.0}


def check_tip(goal, label):
    for _ in range(10):  # 0.5 s: the motors settle on the last IK solution
        watch()
    pose = sim.getObjectPose(tip, -1)
    off, angle = math.dist(pose[:3], goal[:3]), turn(pose[3:], goal[3:])
    print(f'{label}: tip within {1000 * off:.1f} mm and {angle:.2f} deg of the goal')
    assert off < 0.005 and angle < 1, (label, pose)


sim.setStepping(True)
sim.startSimulation()
step_until('ready', 20)
initial_pose, initial_config = call('remoteApi_getPoseAndConfig')
assert len(initial_config) == 7 and initial_pose == sim.getObjectPose(target, -1), (initial_pose, initial_config)

lower = [initial_pose[0] + 0.05, -0.05, initial_pose[2] - 0.12, *initial_pose[3:]]
call('remoteApi_movementDataFunction', mov('m1', lower))
call('remoteApi_executeMovement', 'm1')
step_until('m1')
check_tip(lower, 'm1')

half = math.sqrt(0.5)
turned = [*lower[:3], -half, 0, 0, -half]  # a quarter turn about x
call('remoteApi_movementDataFunction', mov('m2', turned))
call('remoteApi_movementDataFunction', mov('m3', initial_pose))
call('remoteApi_executeMovement', 'm2')
call('remoteApi_executeMovement', 'm3')
step_until('m2')
at_m2 = sim.getObjectPose(target, -1)  # m3 began in the same step: one increment from rest
assert math.dist(at_m2[:3], turned[:3]) < 1e-3 and turn(at_m2[3:], turned[3:]) < 0.5, at_m2
step_until('m3')
assert seen[-3:] == ['m1', 'm2', 'm3'], seen
check_tip(initial_pose, 'm2, m3')

# poses at the simulation step (0.05 s) along a circle in the y-z plane: each one the target's
dt = sim.getSimulationTimeStep()
times = [round(k * dt, 3) for k in range(25)]
x, y0, z0 = initial_pose[:3]
ring = [(y0 + 0.06 * math.sin(2 * math.pi * t / times[-1]), z0 - 0.06 + 0.06 * math.cos(2 * math.pi * t / times[-1]))
        for t in times]
qx, qy, qz, qw = initial_pose[3:]
n = len(times)
call('remoteApi_movementDataFunction', {
    'id': 'p1', 'type': 'pts', 'times': times, 'x': [x] * n, 'y': [p[0] for p in ring], 'z': [p[1] for p in ring],
    'qx': [qx] * n, 'qy': [qy] * n, 'qz': [qz] * n, 'qw': [qw] * n})
call('remoteApi_executeMovement', 'p1')
path, far = [], 0.0
while seen[-1] != 'p1':
    watch()
    pose = sim.getObjectPose(target, -1)
    if not path or path[-1] != pose:
        path.append(pose)
    far = max(far, math.dist(sim.getObjectPose(tip, -1)[:3], initial_pose[:3]))
    assert len(path) < 100, 'p1 not executed'
expected = [[x, *p] for p in ring]
close = [max(abs(a - b) for a, b in zip(p[:3], e)) < 1e-9 for p, e in zip(path[-n + 1:], expected[1:])]
assert len(path) >= n - 1 and all(close), (len(path), close)
print(f'p1: the target went through all {n} poses; the tip went {100 * far:.1f} cm from the start (the circle: 12 cm)')
assert 0.10 < far < 0.13, far
check_tip(initial_pose, 'p1')
sim.stopSimulation()
print('OK ik_signals')
