"""Movements handed to a scene's threaded child script through script functions and a string
signal, in the style of CoppeliaSim 4.3-4.5's ZMQ remote API examples sendMovementSequence-mov.py,
-pts.py and sendSimultan2MovementSequences-mov.py: the scene (messaging/movementViaRemoteApi.ttt,
simx's MJCF stand-in) is already loaded; each arm's script takes movement data with
'remoteApi_movementDataFunction@/<arm>', executes an id with 'remoteApi_executeMovement@/<arm>'
(sim.callScriptFunction, sim.scripttype_childscript) and says which id it executed in the string
signal '/<arm>_executedMovId'. This program steps the simulation itself (stepping mode) and
watches every step: both arms at once, two movements queued back to back, then points with times.

Port: SIMX_ZMQ_PORT (default 23000). Exits non-zero on failure.
"""

import math
import os

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')
arms = ['/blueArm', '/redArm']
joints = {arm: [sim.getObject(arm + '/joint', {'index': i}) for i in range(6)] for arm in arms}
deg = math.radians
seen = {arm: [] for arm in arms}  # the signal's values, one entry per change


def watch():
    """One step; the arms' signals noted when they change."""
    sim.step()
    for arm in arms:
        s = sim.getStringSignal(arm + '_executedMovId')
        if not seen[arm] or seen[arm][-1] != s:
            seen[arm].append(s)


def step_until(arm, id_, limit=400):
    for n in range(limit):
        if seen[arm] and seen[arm][-1] == id_:
            return n
        watch()
    raise AssertionError(f'{arm}: {id_!r} not executed in {limit} steps; the signal said {seen[arm]}')


def send(arm, data):
    sim.callScriptFunction('remoteApi_movementDataFunction@' + arm, sim.scripttype_childscript, data)


def execute(arm, id_):
    sim.callScriptFunction('remoteApi_executeMovement@' + arm, sim.scripttype_childscript, id_)


def mov(id_, config, vel=None, accel=deg(300)):
    return {'id': id_, 'type': 'mov', 'targetConfig': config, 'targetVel': vel or [0] * 6,
            'maxVel': [deg(90)] * 6, 'maxAccel': [accel] * 6, 'maxJerk': [deg(3000)] * 6}


def settle_and_check(arm, config, label):
    for _ in range(10):  # 0.5 s: the position control settles on the last target
        watch()
    q = [sim.getJointPosition(h) for h in joints[arm]]
    error = max(abs(a - b) for a, b in zip(q, config))
    print(f'{arm} {label}: joints within {math.degrees(error):.2f} deg of {[round(math.degrees(c)) for c in config]}')
    assert error < deg(1), (arm, label, q)


sim.setStepping(True)
sim.startSimulation()
for arm in arms:
    step_until(arm, 'ready', 20)

# the same movement for both arms, the red one with less acceleration: it ends later
goal = [deg(a) for a in (40, -30, 50, 60, -20, 30)]
send('/blueArm', mov('a1', goal))
send('/redArm', mov('a1', goal, accel=deg(150)))
execute('/blueArm', 'a1')
execute('/redArm', 'a1')
blue = step_until('/blueArm', 'a1')
red = step_until('/redArm', 'a1') + blue
targets = [sim.getJointTargetPosition(h) for h in joints['/blueArm']]
assert max(abs(a - b) for a, b in zip(targets, goal)) < 1e-6, targets
print(f'both arms: a1 executed after {blue} steps (blue) and {red} steps (red)')
assert red > blue, (blue, red)
for arm in arms:
    settle_and_check(arm, goal, 'a1')

# two movements queued: the second starts where the first ends, at the first's end velocity
send('/blueArm', mov('a2', [0.0] * 6, vel=[deg(-30), deg(20), 0, 0, 0, 0]))
send('/blueArm', mov('a3', [deg(-20)] + [0.0] * 5))
execute('/blueArm', 'a2')
execute('/blueArm', 'a3')
over = 0.0  # joint 2 arrives at 0 moving at 20 deg/s: a3 starting from there carries it past 0
while seen['/blueArm'][-1] != 'a3':
    watch()
    over = max(over, sim.getJointTargetPosition(joints['/blueArm'][1]))
    assert sim.getSimulationTime() < 60, seen['/blueArm']
assert seen['/blueArm'][-3:] == ['a1', 'a2', 'a3'], seen['/blueArm']
print(f'a2, a3: joint 2 carried {math.degrees(over):.1f} deg past a2\'s end by its end velocity')
assert over > deg(1), over
settle_and_check('/blueArm', [deg(-20)] + [0.0] * 5, 'a2, a3')

# points at the simulation step (0.05 s): the script sets each point as a target, in order
dt = sim.getSimulationTimeStep()
times = [round(k * dt, 3) for k in range(21)]
points = {f'j{j + 1}': [deg(-20 if j == 0 else 0) + deg(30 * (j + 1) / 6) * math.sin(math.pi * t / times[-1])
                        for t in times] for j in range(6)}
send('/blueArm', {'id': 'p1', 'type': 'pts', 'times': times, **points})
execute('/blueArm', 'p1')
path, peak = [], [0.0] * 6
while seen['/blueArm'][-1] != 'p1':
    watch()
    target = [sim.getJointTargetPosition(h) for h in joints['/blueArm']]
    if not path or path[-1] != target:
        path.append(target)
    peak = [max(p, abs(sim.getJointPosition(h))) for p, h in zip(peak, joints['/blueArm'])]
    assert len(path) < 100, 'p1 not executed'
expected = [[points[f'j{j + 1}'][k] for j in range(6)] for k in range(len(times))]
start = next(i for i, p in enumerate(path) if max(abs(a - b) for a, b in zip(p, expected[1])) < 1e-9)
assert all(max(abs(a - b) for a, b in zip(p, e)) < 1e-9 for p, e in zip(path[start:], expected[1:])), path
assert len(path) - start == len(expected) - 1, (len(path), start)
top = [max(abs(v) for v in points[f'j{j + 1}']) for j in range(6)]
print(f'p1: the targets went through all {len(times)} points; the joints peaked at '
      f'{[round(math.degrees(p), 1) for p in peak]} deg (the points at {[round(math.degrees(p), 1) for p in top]})')
assert all(abs(p - t) < deg(3) for p, t in zip(peak[1:], top[1:])), peak
settle_and_check('/blueArm', expected[-1], 'p1')

try:
    execute('/blueArm', 'nothing')
except Exception as exc:  # the script's error comes back to the client
    assert 'no movement data with id nothing' in str(exc), exc
else:
    raise AssertionError('an unknown id was accepted')
try:
    send('/blueArm', mov('a9', [0.0] * 8))
except Exception as exc:
    assert 'moves 8 joints; the arm has 7' in str(exc), exc
else:
    raise AssertionError('8 joints for a 7-joint arm were accepted')
sim.stopSimulation()
print('OK arm_signals')
