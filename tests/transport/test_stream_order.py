"""V-REP's synchronous-mode idiom: after ``simxSynchronousTrigger`` + ``simxGetPingTime``, the
streamed values in the inbox (``simx_opmode_buffer``) are those of the step just run, images
included, also when the server's link to the client has no room for the update at once. After a
trigger alone, the inbox holds the streamed values of the pass that executed the trigger, and
``simxGetLastCmdTime`` their time: one step more at every trigger.

simx used to publish a step's stream update with images from the render thread while the ping's
reply went at once: the buffer held the previous step's values 9 times in 10. Later, a
synchronous client's small updates went with Zenoh's "drop" congestion control: when the link's
queue had no room within ``wait_before_drop`` (1 ms), the update was dropped and the client read
the previous step's values (about once in 300 steps of ``simx/UR5BallReach-v0`` on the project's
loaded 2-core machine, so two runs with the same seed differed: issue 44).
"""

from __future__ import annotations

import vrep

from conftest import SCENE, ServerProcess, free_port

B, S, BUF = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming, vrep.simx_opmode_buffer

#: a link whose queue is "full" for anything not sent at once (drop after 1 microsecond)
CONGESTED = ("{transport: {link: {tx: {queue: {congestion_control: {drop: "
             "{wait_before_drop: 1, max_wait_before_drop_fragments: 1}}}}}}}")


def _stale_steps(steps: int, *server_args: str, small_image: bool = True,
                 depth: bool = False) -> tuple[list[int], float]:
    """Run ``steps`` synchronous steps of a server started with ``server_args``, streaming
    UR5_joint1 and kinect_rgb (64x48 with ``small_image``, else 640x480) and, with ``depth``,
    kinect_depth's depth buffer; after each trigger + ping compare the buffered values with what a
    second client reads blocking. Returns the steps whose buffered values were not the step's and
    the joint's last true position (rad)."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", *server_args, ports=ports)
    cid = watcher = -1
    try:
        cid = vrep.simxStart("127.0.0.1", ports[0], True, True, 5000, 5)
        watcher = vrep.simxStart("127.0.0.1", ports[1], True, True, 5000, 5)  # reads the truth
        assert cid >= 0 and watcher >= 0
        joint = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
        cam = vrep.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
        if small_image:
            assert vrep.simxSetObjectIntParameter(cid, cam, vrep.sim_visionintparam_resolution_x, 64, B) == 0
            assert vrep.simxSetObjectIntParameter(cid, cam, vrep.sim_visionintparam_resolution_y, 48, B) == 0
        assert vrep.simxSynchronous(cid, True) == 0 and vrep.simxStartSimulation(cid, B) == 0
        vrep.simxGetJointPosition(cid, joint, S)
        vrep.simxGetVisionSensorImage(cid, cam, 0, S)
        if depth:  # 640x480: 900 KB a step with the image
            vrep.simxGetVisionSensorDepthBuffer(cid, vrep.simxGetObjectHandle(cid, "kinect_depth", B)[1], S)
        stale = []
        q_true = 0.0
        for i in range(steps):
            vrep.simxSetJointTargetPosition(cid, joint, 0.05 * i, vrep.simx_opmode_oneshot)
            assert vrep.simxSynchronousTrigger(cid) == 0
            vrep.simxGetPingTime(cid)
            rc, q = vrep.simxGetJointPosition(cid, joint, BUF)
            rc_img, _, img = vrep.simxGetVisionSensorImage(cid, cam, 0, BUF)
            rc_true, q_true = vrep.simxGetJointPosition(watcher, joint, B)
            rc_true_img, _, img_true = vrep.simxGetVisionSensorImage(watcher, cam, 0, B)
            assert rc == rc_img == rc_true == rc_true_img == 0
            if abs(q - q_true) > 1e-6 or img != img_true:
                stale.append(i)
        return stale, q_true
    finally:
        for c in (cid, watcher):
            if c >= 0:
                vrep.simxFinish(c)
        srv.stop()


def test_streamed_values_after_trigger_and_ping_are_the_steps():
    stale, q_true = _stale_steps(30)
    assert q_true > 0.5  # the joint moved: stale values would differ from the truth
    assert stale == [], f"buffer values of an earlier step after trigger + ping at steps {stale}"


def test_synchronous_streams_are_never_dropped(tmp_path):
    """An operator's Zenoh config makes the drop wait 1 microsecond, so that every update of a
    640x480 image and depth stream (about 15 of Zenoh's batches) meets a full queue: before the
    fix every step's values were the previous step's."""
    config = tmp_path / "zenoh.json5"
    config.write_text(CONGESTED)
    stale, q_true = _stale_steps(20, "--zenoh-config", str(config), small_image=False, depth=True)
    assert q_true > 0.3  # the joint moved: an earlier step's value differs from the truth
    assert stale == [], f"buffer values of an earlier step after trigger + ping at steps {stale}"


def test_after_a_trigger_alone_the_clock_and_the_buffer_advance_one_step():
    """A line follower's loop: trigger, read the stream with ``simx_opmode_buffer``, read the
    clock with ``simxGetLastCmdTime``, no ping. As in V-REP (simExtRemoteApi's
    ``CSimxSocket::_executeCommands``: the trigger and the streamed commands run in the same pass,
    before its main script, and their replies travel together), each trigger's clock is the one
    of the pass that executed it, one step after the previous trigger's, and the buffered value
    is the joint's position at that time (a second client records the truth at every step).
    simx used to put a step's update right after the step, which raced the trigger's reply and
    the program's read: the clock advanced by 0 or 2 steps about one time in three."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", ports=ports)
    cid = watcher = -1
    try:
        cid = vrep.simxStart("127.0.0.1", ports[0], True, True, 5000, 5)
        watcher = vrep.simxStart("127.0.0.1", ports[1], True, True, 5000, 5)
        assert cid >= 0 and watcher >= 0
        joint = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
        assert vrep.simxSynchronous(cid, True) == 0 and vrep.simxStartSimulation(cid, B) == 0
        vrep.simxGetJointPosition(cid, joint, S)
        assert vrep.simxGetPingTime(cid)[0] == 0
        truth = {}  # simulation time (ms) -> the joint's position then

        def record() -> None:
            rc, q = vrep.simxGetJointPosition(watcher, joint, B)
            assert rc == 0
            truth[vrep.simxGetLastCmdTime(watcher)] = q

        record()
        times, values = [], []
        for i in range(40):
            vrep.simxSetJointTargetPosition(cid, joint, 0.05 * i, vrep.simx_opmode_oneshot)
            assert vrep.simxSynchronousTrigger(cid) == 0
            rc, q = vrep.simxGetJointPosition(cid, joint, BUF)
            assert rc == 0
            times.append(vrep.simxGetLastCmdTime(cid))
            values.append(q)
            record()  # after the step this trigger released
        steps = [b - a for a, b in zip(times, times[1:])]
        assert steps == [50] * 39, f"clock steps after each trigger: {steps}"
        assert times[0] == min(truth)  # the first trigger's pass: before any step
        wrong = [k for k, (t, q) in enumerate(zip(times, values)) if truth.get(t) != q]
        assert wrong == [], f"buffered values not of the clock's step after triggers {wrong}"
        assert abs(values[-1] - values[0]) > 0.3  # the joint moved: another step's value would differ
    finally:
        for c in (cid, watcher):
            if c >= 0:
                vrep.simxFinish(c)
        srv.stop()
