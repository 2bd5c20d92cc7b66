"""Dummies, an asynchronous run and a stepped run, in the style of CoppeliaSim's ZMQ remote API
example simpleTest.py.

Port: SIMX_ZMQ_PORT (default 23000). Exits non-zero on failure.
"""

import os
import time

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')

handles = [sim.createDummy(0.01, 12 * [0]) for _ in range(5)]
for i, h in enumerate(handles):
    sim.setObjectPosition(h, -1, [0.01 * i, 0.01 * i, 0.01 * i])
assert max(abs(v - 0.04) for v in sim.getObjectPosition(handles[-1], -1)) < 1e-9

sim.startSimulation()
calls = 0
while (t := sim.getSimulationTime()) < 0.5:  # the simulation runs on its own: the client only looks
    calls += 1
sim.addLog(sim.verbosity_scriptinfos, f'asynchronous run: {calls} calls until t = {t:.2f} s')
sim.stopSimulation()
while sim.getSimulationState() != sim.simulation_stopped:
    time.sleep(0.1)

sim.setStepping(True)
sim.startSimulation()
for _ in range(10):  # in stepping mode the simulation advances one step per sim.step()
    sim.step()
t = sim.getSimulationTime()
sim.stopSimulation()
print(f'asynchronous: {calls} calls in 0.5 s of simulation; stepped: 10 steps to t = {t:.3f} s')
assert abs(t - 10 * sim.getSimulationTimeStep()) < 1e-6

for h in handles:
    sim.removeObject(h)
assert not any(sim.isHandle(h) for h in handles)
print('OK dummies')
