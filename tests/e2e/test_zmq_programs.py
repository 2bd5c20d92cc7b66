"""CoppeliaSim 4.x programs (ZMQ remote API, the official client) run unchanged against simx-server,
each as a subprocess against a fresh server, as a user runs them.

The programs (tests/e2e/zmq_programs/) are written in the style of CoppeliaSim's own examples
(clients/python/ of CoppeliaRobotics/zmqRemoteApi): ``ur5_pick.py`` a typical manipulation
program on the bundled UR5 scene (stepping, joint targets, the Kinect's image as NumPy, the RG2's
child script), ``p_controller.py`` (pController.py), ``image_relay.py``
(synchronousImageTransmission.py), ``dummies.py`` (simpleTest.py) and ``movement.py``
(simpleMovement.py: three clients in stepping mode from threads, sim.moveToConfig, sim.moveToPose),
``arm_callback.py`` (sendMovementSequence-simMoveToConfig.py) and ``ik_callback.py``
(sendIkMovementSequence-simMoveToPose.py): CoppeliaSim 4.3-4.5's positional sim.moveToConfig /
sim.moveToPose with a Python callback, ``arm_signals.py`` (sendMovementSequence-mov.py, -pts.py,
sendSimultan2MovementSequences-mov.py) and ``ik_signals.py`` (sendIkMovementSequence-mov.py,
-pts.py): movements handed to the scene's threaded child scripts through script functions and a
string signal. The scenes they load by CoppeliaSim's names
(``messaging/*.ttt``), or that the server starts with for the last four (as those examples expect
their scene loaded), are simx's MJCF stand-ins in tests/scenes/zmq/.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import SCENE, ServerProcess, free_port

pytest.importorskip("coppeliasim_zmqremoteapi_client")

PROGRAMS = Path(__file__).resolve().parent / "zmq_programs"
SCENES = Path(__file__).resolve().parents[1] / "scenes" / "zmq"
#: Programs that expect their scene loaded when they start, as their CoppeliaSim examples do.
PRELOADED = {"arm_callback": SCENES / "messaging" / "movementViaRemoteApi.xml",
             "ik_callback": SCENES / "messaging" / "ikMovementViaRemoteApi.xml",
             "arm_signals": SCENES / "messaging" / "movementViaRemoteApi.xml",
             "ik_signals": SCENES / "messaging" / "ikMovementViaRemoteApi.xml"}
#: Programs that read vision sensors' images.
READ_IMAGES = {"ur5_pick", "image_relay"}


@pytest.mark.parametrize("program,expected", [
    ("ur5_pick", ["arm reached its pose", "the ball covers", "rg2Close answered ([], [-0.05], [], '')"]),
    ("p_controller", ["45.0 deg reached", "90.0 deg reached", "-89.0 deg reached", "0.0 deg reached"]),
    ("image_relay", ["20 images of 256x256 relayed"]),
    ("dummies", ["stepped: 10 steps to t = 0.500 s"]),
    ("movement", ["blueRobot: its configuration reached", "redRobot: its configuration reached", "raised by 0.200 m"]),
    ("arm_callback", ["motion 1: ", "motion 2: ", "motion 3: "]),
    ("ik_callback", ["pose 1: ", "pose 2: ", "pose 3: "]),
    ("arm_signals", ["both arms: a1 executed", "a2, a3: joint 2 carried", "p1: the targets went through all 21 points"]),
    ("ik_signals", ["m1: tip within", "m2, m3: tip within", "p1: the target went through all 25 poses"]),
])
def test_program_runs_unchanged(program, expected, tmp_path):
    port = free_port()
    scene = PRELOADED.get(program, SCENE)
    # the programs that read no image get a server that makes no renderer at load (0.25 s of CPU)
    renderers = "at-load" if program in READ_IMAGES else "on-demand"
    server = ServerProcess(str(scene), "--stopped", "--zmq-port", str(port), "--scene-path", str(SCENES),
                           renderers=renderers)
    try:
        env = dict(os.environ, SIMX_ZMQ_PORT=str(port), SIMX_SAVE_DIR=str(tmp_path))
        run = subprocess.run([sys.executable, str(PROGRAMS / f"{program}.py")], env=env, capture_output=True,
                             text=True, timeout=300, cwd=tmp_path)
    finally:
        log = server.stop()
    assert run.returncode == 0, f"{run.stdout}\n{run.stderr}\n--- server log ---\n{log[-3000:]}"
    assert f"OK {program}" in run.stdout
    for text in expected:
        assert text in run.stdout, run.stdout
    assert "Traceback" not in log, log[-3000:]
    if program == "ur5_pick":
        assert (tmp_path / "kinect.png").stat().st_size > 10_000
