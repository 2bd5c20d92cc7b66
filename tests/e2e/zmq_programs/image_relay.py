"""Images relayed by the client from an active vision sensor to a passive one, step by step, in
the style of CoppeliaSim's ZMQ remote API example synchronousImageTransmission.py.

Port: SIMX_ZMQ_PORT (default 23000). Exits non-zero on failure.
"""

import os

import numpy as np
from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')

sim.loadScene(sim.getStringParam(sim.stringparam_scenedefaultdir) + '/messaging/synchronousImageTransmissionViaRemoteApi.ttt')
camera = sim.getObject('/VisionSensor')
passive = sim.getObject('/PassiveVisionSensor')

sim.setStepping(True)
sim.startSimulation()
first = None
frames = 0
while sim.getSimulationTime() < 1.0:
    img, res = sim.getVisionSensorImg(camera)
    sim.setVisionSensorImg(passive, img)
    echoed, _ = sim.getVisionSensorImg(passive)
    assert echoed == img, 'the passive sensor shows the image written into it'
    first = first if first is not None else np.frombuffer(img, dtype=np.uint8)
    frames += 1
    sim.step()
last = np.frombuffer(img, dtype=np.uint8)
changed = np.count_nonzero(first != last) / first.size
print(f'{frames} images of {res[0]}x{res[1]} relayed; {changed:.1%} of the bytes changed as the cross turned')
assert frames == 20 and changed > 0.01
sim.stopSimulation()
print('OK image_relay')
