"""V-REP's synchronous-mode idiom: after ``simxSynchronousTrigger`` + ``simxGetPingTime``, the
streamed values in the inbox (``simx_opmode_buffer``) are those of the step just run, images
included. simx used to publish a step's stream update with images from the render thread
while the ping's reply went at once: the buffer held the previous step's values 9 times in 10.
"""

from __future__ import annotations

import vrep

from conftest import SCENE, ServerProcess, free_port

B, S, BUF = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming, vrep.simx_opmode_buffer


def test_streamed_values_after_trigger_and_ping_are_the_steps():
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", ports=ports)
    cid = watcher = -1
    try:
        cid = vrep.simxStart("127.0.0.1", ports[0], True, True, 5000, 5)
        watcher = vrep.simxStart("127.0.0.1", ports[1], True, True, 5000, 5)  # reads the truth
        assert cid >= 0 and watcher >= 0
        joint = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
        cam = vrep.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
        assert vrep.simxSetObjectIntParameter(cid, cam, vrep.sim_visionintparam_resolution_x, 64, B) == 0
        assert vrep.simxSetObjectIntParameter(cid, cam, vrep.sim_visionintparam_resolution_y, 48, B) == 0
        assert vrep.simxSynchronous(cid, True) == 0 and vrep.simxStartSimulation(cid, B) == 0
        vrep.simxGetJointPosition(cid, joint, S)
        vrep.simxGetVisionSensorImage(cid, cam, 0, S)
        stale = []
        for i in range(30):
            vrep.simxSetJointTargetPosition(cid, joint, 0.05 * i, vrep.simx_opmode_oneshot)
            assert vrep.simxSynchronousTrigger(cid) == 0
            vrep.simxGetPingTime(cid)
            rc, q = vrep.simxGetJointPosition(cid, joint, BUF)
            rc_img, res, img = vrep.simxGetVisionSensorImage(cid, cam, 0, BUF)
            rc_true, q_true = vrep.simxGetJointPosition(watcher, joint, B)
            rc_true_img, res_true, img_true = vrep.simxGetVisionSensorImage(watcher, cam, 0, B)
            assert rc == rc_img == rc_true == rc_true_img == 0
            if abs(q - q_true) > 1e-6 or img != img_true:
                stale.append(i)
        assert q_true > 0.5  # the joint moved: stale values would differ from the truth
        assert stale == [], f"buffer values of an earlier step after trigger + ping at steps {stale}"
    finally:
        for c in (cid, watcher):
            if c >= 0:
                vrep.simxFinish(c)
        srv.stop()
