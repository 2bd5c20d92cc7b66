"""A grasp-and-push program in the style of visual-pushing-grasping's ``robot.py``
(simulation mode), written for simx's scene ``scenes/ur5_ik.xml``; only the legacy API.

It never sets an arm joint: it moves the dummy ``UR5_target`` and the scene's IK group makes
``UR5_tip`` follow. Steps: connect (port 19997 unless ``--port``), restart the simulation, wait
for the arm to settle on its target, take an RGB + depth image from ``Vision_sensor_persp``,
write three cube meshes (.obj) and add them through the scene's ``remoteApiCommandServer``
script (``importShape``), grasp the first cube (move above, rotate, descend, close, lift) and
check it was lifted, then push the second one and check it moved.

Prints one JSON object per line (``{"step": ..., ...}``) and exits 0 when every check held,
1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

import vrep

BLOCK = vrep.simx_opmode_blocking
TIP_TOLERANCE = 0.002  # m: the tip rests within this of its target
CUBE = 0.05  # m, edge of the cubes
WORKSPACE = np.array([[-0.724, -0.276], [-0.224, 0.224], [0.0, 0.4]])  # x, y, z (m)
DOWN = (math.pi / 2, 0.0, math.pi / 2)  # Euler angles of a gripper pointing down


def report(step: str, **values) -> None:
    print(json.dumps({"step": step, **values}), flush=True)


def check(ok: bool, what: str) -> None:
    if not ok:
        report("failed", what=what)
        sys.exit(1)


def write_cube(path: str, edge: float) -> None:
    """An .obj cube of ``edge`` m centred on its origin (outward faces)."""
    s = edge / 2
    vertices = [(x, y, z) for x in (-s, s) for y in (-s, s) for z in (-s, s)]
    faces = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]  # counter-clockwise seen from outside
    with open(path, "w") as f:
        f.writelines(f"v {x} {y} {z}\n" for x, y, z in vertices)
        f.writelines("f " + " ".join(map(str, face)) + "\n" for face in faces)


class Robot:
    """The simulated UR5 + RG2 through the legacy remote API."""

    def __init__(self, port: int):
        vrep.simxFinish(-1)
        self.client = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
        check(self.client != -1, f"connect to 127.0.0.1:{port}")
        self.target = self.handle("UR5_target")
        self.tip = self.handle("UR5_tip")
        self.gripper = self.handle("RG2_openCloseJoint")
        self.camera = self.handle("Vision_sensor_persp")

    def handle(self, name: str) -> int:
        rc, h = vrep.simxGetObjectHandle(self.client, name, BLOCK)
        check(rc == vrep.simx_return_ok, f"handle of {name}")
        return h

    def position(self, handle: int) -> np.ndarray:
        rc, p = vrep.simxGetObjectPosition(self.client, handle, -1, BLOCK)
        check(rc == vrep.simx_return_ok, "simxGetObjectPosition")
        return np.array(p)

    def restart(self) -> None:
        vrep.simxStopSimulation(self.client, BLOCK)
        vrep.simxStartSimulation(self.client, BLOCK)
        self.wait_tip()

    def wait_tip(self, timeout: float = 20.0) -> float:
        """Poll until the tip rests on the target; returns the last distance (m)."""
        deadline = time.monotonic() + timeout
        last = []
        while time.monotonic() < deadline:
            d = float(np.linalg.norm(self.position(self.tip) - self.position(self.target)))
            last = (last + [d])[-5:]
            if len(last) == 5 and max(last) < TIP_TOLERANCE:
                return d
        check(False, f"tip within {TIP_TOLERANCE} m of the target (last {last})")
        return math.inf

    def move_to(self, goal, step: float = 0.02) -> None:
        """Move the target in ``step`` m increments (as that program does), then wait for the tip."""
        here = self.position(self.target)
        goal = np.asarray(goal, dtype=float)
        n = max(1, int(math.ceil(np.linalg.norm(goal - here) / step)))
        for k in range(1, n + 1):
            vrep.simxSetObjectPosition(self.client, self.target, -1, (here + (goal - here) * k / n).tolist(), BLOCK)
        self.wait_tip()

    def rotate_to(self, angle: float) -> None:
        """Turn the gripper (pointing down) by ``angle`` rad about the vertical."""
        vrep.simxSetObjectOrientation(self.client, self.target, -1, [DOWN[0], angle, DOWN[2]], BLOCK)
        self.wait_tip()

    def _drive_gripper(self, velocity: float) -> float:
        vrep.simxSetJointForce(self.client, self.gripper, 100, BLOCK)
        vrep.simxSetJointTargetVelocity(self.client, self.gripper, velocity, BLOCK)
        rc, previous = vrep.simxGetJointPosition(self.client, self.gripper, BLOCK)
        stamp = vrep.simxGetLastCmdTime(self.client)
        deadline = time.monotonic() + 10
        still = 0
        while time.monotonic() < deadline and still < 3:  # until it stops moving
            rc, q = vrep.simxGetJointPosition(self.client, self.gripper, BLOCK)
            now = vrep.simxGetLastCmdTime(self.client)  # simulation time of that reading (ms)
            if now != stamp:  # compare readings of different steps only, whatever the server's pacing
                still = still + 1 if abs(q - previous) < 1e-5 else 0
                previous, stamp = q, now
        return previous

    def close_gripper(self) -> float:
        """Close at 0.5 m/s with 100 N; returns the joint's position where it stopped (m:
        -0.047 closed on nothing .. 0.036 open)."""
        return self._drive_gripper(-0.5)

    def open_gripper(self) -> float:
        return self._drive_gripper(0.5)

    def camera_data(self) -> tuple[np.ndarray, np.ndarray]:
        rc, res, image = vrep.simxGetVisionSensorImage(self.client, self.camera, 0, BLOCK)
        check(rc == vrep.simx_return_ok, "simxGetVisionSensorImage")
        rgb = np.array(image).astype(np.int16).astype(np.uint8).reshape(res[1], res[0], 3)[::-1]
        rc, res, depth = vrep.simxGetVisionSensorDepthBuffer(self.client, self.camera, BLOCK)
        check(rc == vrep.simx_return_ok, "simxGetVisionSensorDepthBuffer")
        near, far = 0.01, 10.0
        depth = near + np.array(depth).reshape(res[1], res[0])[::-1] * (far - near)
        return rgb, depth

    def add_object(self, mesh: str, name: str, position, angle: float, color) -> int:
        rc, ints, _, _, _ = vrep.simxCallScriptFunction(
            self.client, "remoteApiCommandServer", vrep.sim_scripttype_childscript, "importShape",
            [0, 0, 255, 0], list(position) + [0.0, 0.0, angle] + list(color), [mesh, name], bytearray(), BLOCK)
        check(rc == vrep.simx_return_ok and len(ints) == 1, f"importShape {name} (rc {rc})")
        return ints[0]

    def grasp(self, position, angle: float) -> bool:
        """Top-down grasp at ``position`` (m) with the fingers turned ``angle`` rad; lifts the
        object 0.2 m. True when the fingers stopped on something (above -0.045, that
        program's rule)."""
        x, y, z = position
        self.open_gripper()
        self.move_to([x, y, z + 0.15])
        self.rotate_to(angle)
        self.move_to([x, y, max(z - 0.01, WORKSPACE[2][0] + 0.02)])
        opening = self.close_gripper()
        report("closed", opening=opening)
        self.move_to([x, y, z + 0.2])
        return opening > -0.045  # not closed on nothing (the joint's closed end is -0.047)

    def push(self, position, direction, length: float = 0.1) -> None:
        """Push along ``direction`` (unit, horizontal) from ``length``/2 behind ``position``."""
        d = np.asarray(direction, dtype=float)
        start = np.asarray(position)[:2] - d * (CUBE / 2 + 0.04)
        self.close_gripper()
        self.move_to([start[0], start[1], 0.15])
        self.move_to([start[0], start[1], 0.025])
        end = start + d * (length + 0.04)
        self.move_to([end[0], end[1], 0.025], step=0.01)
        self.move_to([end[0], end[1], 0.15])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, default=19997)
    parser.add_argument("--mesh-dir", default=".", help="where the cube meshes are written")
    args = parser.parse_args()
    started = time.monotonic()
    robot = Robot(args.port)
    robot.restart()
    report("restarted", tip_error=float(np.linalg.norm(robot.position(robot.tip) - robot.position(robot.target))))

    rgb, depth = robot.camera_data()
    table = float(np.median(depth))  # most of the image is the table top, 1 m under the camera
    report("camera", shape=list(rgb.shape), depth_min=float(depth.min()), depth_median=table,
           depth_max=float(depth.max()), colours=int(len(np.unique(rgb.reshape(-1, 3), axis=0))))
    check(rgb.shape == (480, 640, 3) and 0.95 < table < 1.1 and float(depth.max()) < 1.3, "camera data")

    places = [(-0.55, 0.1, CUBE / 2), (-0.45, -0.1, CUBE / 2), (-0.65, -0.15, CUBE / 2)]
    colors = [(0.9, 0.2, 0.2), (0.2, 0.8, 0.2), (0.2, 0.3, 0.9)]
    cubes = []
    for i, (place, color) in enumerate(zip(places, colors)):
        mesh = os.path.abspath(os.path.join(args.mesh_dir, f"cube_{i}.obj"))
        write_cube(mesh, CUBE)
        cubes.append(robot.add_object(mesh, f"shape_{i:02d}", place, 0.3 * i, color))
    report("added", handles=cubes)
    # The cubes' tops, seen 0.95 m away through the 618.62 px focal length that program assumes
    # (the arm out of the way first).
    robot.move_to([-0.25, 0.35, 0.35])
    _, depth = robot.camera_data()
    tops = int(np.count_nonzero(np.abs(depth - (1.0 - CUBE)) < 0.01))
    expected = 3 * (CUBE * 618.62 / (1.0 - CUBE)) ** 2
    report("cube_tops", pixels=tops, expected=expected)
    check(abs(tops - expected) < 0.1 * expected, "the cubes' tops in the depth image")

    settled = [robot.position(h) for h in cubes]
    grasped = robot.grasp(settled[0], 0.0)
    lifted = robot.position(cubes[0])
    report("grasped", grasped=grasped, before=settled[0].tolist(), after=lifted.tolist())
    check(grasped and lifted[2] > settled[0][2] + 0.1, "the first cube lifted by more than 0.1 m")
    rest = robot.wait_tip()
    report("tip_at_rest", error=rest)
    robot.open_gripper()

    before = robot.position(cubes[1])
    robot.push(before, (-1.0, 0.0))
    after = robot.position(cubes[1])
    moved = float(np.linalg.norm((after - before)[:2]))
    report("pushed", before=before.tolist(), after=after.tolist(), moved=moved)
    check(moved > 0.05, "the second cube pushed by more than 5 cm")
    vrep.simxFinish(robot.client)
    report("done", seconds=time.monotonic() - started)


if __name__ == "__main__":
    main()
