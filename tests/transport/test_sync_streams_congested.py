"""V-REP's synchronous-mode guarantee on a congested link: after ``simxSynchronousTrigger`` +
``simxGetPingTime`` the inbox holds the step's streamed values even when the server's link to
the client has no room for the update at once.

simx put a synchronous client's small stream updates with Zenoh's "drop" congestion control:
when the link's queue had no room within ``wait_before_drop`` (1 ms), the update was dropped
and the client read the previous step's values. On the project's loaded 2-core machine that
happened about once in 300 steps of ``simx/UR5BallReach-v0`` and made two runs with the same
seed differ (issue 44). Here an operator's Zenoh config makes the wait 1 microsecond, so that
every update of a 640x480 image stream (about 15 of Zenoh's batches) meets a full queue: before
the fix every step's values were the previous step's.
"""

from __future__ import annotations

import vrep

from conftest import SCENE, ServerProcess, free_port

B, S, BUF = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming, vrep.simx_opmode_buffer

#: a link whose queue is "full" for anything not sent at once (drop after 1 microsecond)
CONGESTED = ("{transport: {link: {tx: {queue: {congestion_control: {drop: "
             "{wait_before_drop: 1, max_wait_before_drop_fragments: 1}}}}}}}")


def test_synchronous_streams_are_never_dropped(tmp_path):
    config = tmp_path / "zenoh.json5"
    config.write_text(CONGESTED)
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", "--zenoh-config", str(config), ports=ports)
    cid = watcher = -1
    try:
        cid = vrep.simxStart("127.0.0.1", ports[0], True, True, 5000, 5)
        watcher = vrep.simxStart("127.0.0.1", ports[1], True, True, 5000, 5)  # reads the truth
        assert cid >= 0 and watcher >= 0
        joint = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
        cam = vrep.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
        depth = vrep.simxGetObjectHandle(cid, "kinect_depth", B)[1]
        assert vrep.simxSynchronous(cid, True) == 0 and vrep.simxStartSimulation(cid, B) == 0
        vrep.simxGetJointPosition(cid, joint, S)
        vrep.simxGetVisionSensorImage(cid, cam, 0, S)  # 640x480: 900 KB a step
        vrep.simxGetVisionSensorDepthBuffer(cid, depth, S)
        stale = []
        for i in range(20):
            vrep.simxSetJointTargetPosition(cid, joint, 0.05 * i, vrep.simx_opmode_oneshot)
            assert vrep.simxSynchronousTrigger(cid) == 0
            vrep.simxGetPingTime(cid)
            rc, q = vrep.simxGetJointPosition(cid, joint, BUF)
            rc_img, _, img = vrep.simxGetVisionSensorImage(cid, cam, 0, BUF)
            rc_true, q_true = vrep.simxGetJointPosition(watcher, joint, B)
            rc_true_img, _, img_true = vrep.simxGetVisionSensorImage(watcher, cam, 0, B)
            assert rc == rc_img == rc_true == rc_true_img == 0
            if q != q_true or img != img_true:
                stale.append(i)
        assert q_true > 0.3  # the joint moved: an earlier step's value differs from the truth
        assert stale == [], f"buffer values of an earlier step after trigger + ping at steps {stale}"
    finally:
        for c in (cid, watcher):
            if c >= 0:
                vrep.simxFinish(c)
        srv.stop()
