"""Joint motions sent with CoppeliaSim 4.3-4.5's positional sim.moveToConfig and a callback, in the
style of CoppeliaSim's ZMQ remote API example sendMovementSequence-simMoveToConfig.py: the scene
(messaging/movementViaRemoteApi.ttt, simx's MJCF stand-in) is already loaded, the simulation
stopped; the joints are found as '/blueArm/joint' with {'index': i}; the client's callback
places the joints each step (their target positions when dynamically enabled in force mode,
else their positions), making calls of its own while the motion waits for it.

Port: SIMX_ZMQ_PORT (default 23000). Exits non-zero on failure.
"""

import math
import os

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')
joints = [sim.getObject('/blueArm/joint', {'index': i}) for i in range(6)]
calls = []


def follow(config, vel, accel, handles):
    calls.append(sim.getSimulationTime())
    for h, q in zip(handles, config):
        if sim.getJointMode(h)[0] == sim.jointmode_force and sim.isDynamicallyEnabled(h):
            sim.setJointTargetPosition(h, q)
        else:
            sim.setJointPosition(h, q)


deg = math.radians
limits = ([deg(100)] * 6, [deg(150)] * 6, [deg(80)] * 6)
sequence = [([deg(a) for a in (80, 60, -70, 45, 90, -30)], None),
            ([deg(a) for a in (-45, 30, 60, 100, 45, 0)], [deg(-40), deg(-10), 0, 0, 0, 0]),
            ([0.0] * 6, None)]
dt = sim.getSimulationTimeStep()
# stepped by this client (CoppeliaSim's example runs free): then the simulation advances only inside
# the motions and waits, and the steps counted between two reads of the time are the motion's own
sim.setStepping(True)
sim.startSimulation()
current = [0.0] * 6
for n, (goal, goal_vel) in enumerate(sequence, 1):
    del calls[:]
    t0 = sim.getSimulationTime()
    pos, vel, accel, time_left = sim.moveToConfig(-1, current, None, None, *limits, goal, goal_vel, follow, joints)
    steps = round((sim.getSimulationTime() - t0) / dt)
    # at the goal, or past it by less than one step at the goal's velocity (Ruckig's last increment)
    assert all(abs(a - b) <= abs(v) * dt + 1e-6 for a, b, v in zip(pos, goal, vel)), pos
    assert all(abs(v - w) < 1e-6 for v, w in zip(vel, goal_vel or [0] * 6)), vel
    assert abs(len(calls) - steps) <= 1, (len(calls), steps)
    assert all(abs(b - a - dt) < 1e-9 for a, b in zip(calls, calls[1:])), 'one step between two callbacks'
    sim.wait(0.5)  # the joints' position control settles on the last target
    reached = [sim.getJointPosition(h) for h in joints]
    error = max(abs(a - b) for a, b in zip(reached, pos))
    print(f'motion {n}: {len(calls)} callbacks in {steps} steps ({steps * dt:.2f} s), end velocity '
          f'{[round(math.degrees(v)) for v in vel]} deg/s, joints within {math.degrees(error):.2f} deg of the end')
    assert error < deg(1), reached
    current = goal
sim.stopSimulation()
print('OK arm_callback')
