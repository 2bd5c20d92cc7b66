"""9. simx-dataset: labelled images per second (render + label + write), issue 13.

Rounds of ``simx-dataset``'s own :func:`simx_client.dataset.generate` (the ball class, the
tutorial pose with 4 degrees of noise, 640x480 JPEGs into a fresh folder each round) against a
server at ``--speed 0``, beside the floor measured in the same rounds on the same server: the
two blocking 640x480 image calls that every labelled image needs (the RGB frame and the
colour-coded frame), with nothing else. The ratio says what labelling and writing add.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

from benchmarks.common import Settings, connect
from benchmarks.procs import Server
from benchmarks.stats import Figure, summary
from simx_client import api
from simx_client import constants as C
from simx_client.dataset import Options, generate

B = C.simx_opmode_blocking


def _image_calls(port: int, n: int) -> float:
    """Images/s of the floor: per image, the RGB frame and the colour-coded frame (blocking)."""
    cid = connect(port)
    try:
        rc, rgb = api.simxGetObjectHandle(cid, "kinect_rgb", B)
        if rc:
            raise RuntimeError(f"simxGetObjectHandle(kinect_rgb) failed: {rc}")
        t0 = time.perf_counter()
        for _ in range(n):
            for mode in (0, 2):  # the scene, then the colour-coded handles
                api.simxSetObjectIntParameter(cid, rgb, C.sim_visionintparam_render_mode, mode, B)
                if api.simxGetVisionSensorImage(cid, rgb, 0, B)[0]:
                    raise RuntimeError("simxGetVisionSensorImage failed")
        rate = n / (time.perf_counter() - t0)
        api.simxSetObjectIntParameter(cid, rgb, C.sim_visionintparam_render_mode, 0, B)
        return rate
    finally:
        api.simxFinish(cid)


def run(s: Settings) -> list[Figure]:
    rounds, per_round = s.n(5, 2), s.n(40, 10)
    rates, floor = [], []
    with Server(s.log_dir, "--speed", "0", name="dataset") as srv:
        for r in range(rounds):
            out = Path(tempfile.mkdtemp(prefix="simx-bench-dataset-"))
            try:  # generate() opens and closes its own connection (one per server and process)
                result = generate(Options(out=out / "ds", classes=[("ball", ["Sphere"])], port=srv.port,
                                          pose=[90, -45, 90, 0, -100, 0], pose_noise=4.0,
                                          count=per_round, seed=r, progress=False))
                rates.append(result.images / result.seconds)
            finally:
                shutil.rmtree(out, ignore_errors=True)
            floor.append(_image_calls(srv.port, per_round))
    return [
        Figure("dataset.images_per_s", "simx-dataset: labelled 640x480 images/s (render + label + write)",
               "1/s", summary(rates), floor={"label": "two blocking image calls per image", **summary(floor)},
               note=f"{rounds} rounds of {per_round} images, ball class, tutorial pose +-4 deg"),
    ]
