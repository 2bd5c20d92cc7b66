"""Issue 32's second round through the ZMQ remote API and the official client, on
tests/scenes/api32/arm.xml: point clouds and octrees, a graph stream recorded while stepping, a
vision sensor and a proximity sensor created at run time, a time-optimal trajectory,
moveToPose in steps, a relocated shape frame, an image encoded to PNG and property values
converted. Port from SIMX_ZMQ_PORT (default 23000). Prints one line per stage; exits non-zero
when off."""

import math
import os

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

client = RemoteAPIClient('localhost', int(os.environ.get('SIMX_ZMQ_PORT', '23000')))
sim = client.require('sim')
obstacle = sim.getObject('/obstacle')  # a 0.1 m cube at (0.35, 0.45, 0)

cloud = sim.createPointCloud(0.05, 20, 0, 2)
n = sim.insertObjectIntoPointCloud(cloud, obstacle, 0, 0.01)
pts = sim.getPointCloudPoints(cloud)
assert n == len(pts) // 3 > 50, n
assert all(abs(pts[i] - 0.35) <= 0.0501 for i in range(0, len(pts), 3))
print('cloud', n)
octree = sim.createOctree(0.05, 0, 1)
sim.insertVoxelsIntoOctree(octree, 0, [0.36, 0.46, 0.01])
result = sim.checkOctreePointOccupancy(octree, 0, [0.37, 0.47, 0.02])
assert result[0] == 1, result
print('octree occupied')

graph = sim.createDummy(0.01)
stream = sim.addGraphStream(graph, 'time', 's')
sim.setStepping(True)
sim.startSimulation()
for _ in range(5):
    sim.setGraphStreamValue(graph, stream, sim.getSimulationTime())
    sim.step()
curve = sim.getGraphCurve(graph, 0, 0)
assert curve[0] == 'time' and curve[3] == curve[4] and len(curve[3]) == 5, curve
print('graph recorded')

cam = sim.createVisionSensor(1, [16, 12, 0, 0], [0.01, 5, math.radians(60), 0, 0, 0, 0, 0, 0, 0, 0])
sim.setObjectPosition(cam, -1, [0.35, 0.45, -0.5])  # under the red obstacle, looking up
img, res = sim.getVisionSensorImg(cam)
r, g, b = img[(6 * 16 + 8) * 3:(6 * 16 + 8) * 3 + 3]
assert res == [16, 12] and r > 150 and g < 100, (r, g, b)
png = sim.saveImage(img, res, 0, '.png', -1)
assert png[:4] == b'\x89PNG'
prox = sim.createProximitySensor(sim.proximitysensor_ray, 0, 0, [0] * 8, [0, 2] + [0] * 13)
sim.setObjectPosition(prox, -1, [0.35, 0.45, -0.5])
detected, dist, _, hit, _ = sim.readProximitySensor(prox)
assert detected == 1 and hit == obstacle and abs(dist - 0.45) < 1e-6, (detected, dist, hit)
print('sensors created')

path, times = sim.generateTimeOptimalTrajectory([0, 0, 1, 1], [0, math.sqrt(2)], [-1, 1, -1, 1], [-2, 2, -2, 2], 200)
assert len(times) == 200 and 1.0 < times[-1] < 3.0, times[-1]
print('trajectory', round(times[-1], 3))

dummy = sim.createDummy(0.01)
motion = sim.moveToPose_init({'object': dummy, 'targetPose': [0.2, 0, 0, 0, 0, 0, 1], 'maxVel': [1] * 4,
                              'maxAccel': [4] * 4, 'maxJerk': [40] * 4})
res = 0
for _ in range(500):
    res, motion = sim.moveToPose_step(motion)
    if res == 1:
        break
sim.moveToPose_cleanup(motion)
assert res == 1 and abs(sim.getObjectPosition(dummy, -1)[0] - 0.2) < 1e-6
print('pose reached')

sim.relocateShapeFrame(obstacle, [0.3, 0.45, 0, 0, 0, 0, 1])
assert abs(sim.getObjectPosition(obstacle, -1)[0] - 0.3) < 1e-9
assert abs(sim.getShapeBB(obstacle)[0] - 0.1) < 1e-9
m = sim.convertPropertyValue([0, 0, 0, 1], sim.propertytype_quaternion, sim.propertytype_matrix3x3)
assert [round(v, 9) for v in m] == [1, 0, 0, 0, 1, 0, 0, 0, 1], m
sim.stopSimulation()
print('OK breadth32')
