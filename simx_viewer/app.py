"""``simx-viewer``: watch a running simx-server in MuJoCo's interactive viewer.

``simx-viewer [--host ADDR] [--port N] [--zenoh-config FILE]`` fetches the server's compiled
model, opens ``mujoco.viewer.launch_passive`` on it and copies every state the server publishes
into the viewer's ``MjData`` (``mj_forward``, ``sync``). Nothing is simulated here and nothing
is sent back: the viewer never changes the server's simulation. MuJoCo's own UI orbits, zooms
and selects; **space** pauses (and resumes) the view: states are then not applied. When the
server's scene is edited or another one is loaded (a new generation), the window is closed and
opened again on the new model. Vision sensors (MJCF cameras with a ``resolution``) are drawn
with their frusta; ``--images`` shows their images (fetched with the legacy streaming calls, as
any program would) in OpenCV windows (:mod:`simx_viewer.images`).

Exit status: 0 when the window is closed, 1 when no server answers (one line on stderr that
says where it looked), 2 for bad arguments.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import signal
import sys
import threading

import mujoco
import numpy as np

from simx_wire import protocol as P
from simx_viewer.framing import default_view, far_enough, scene_box
from simx_viewer.link import DEFAULT_TIMEOUT, NoServerError, ViewerLink, ViewerModel

log = logging.getLogger("simx.viewer")

#: Length of the vision sensors' drawn frusta, m.
FRUSTUM_LENGTH = 0.5
_SPACE = 32  # GLFW's key code of the space bar (key_callback)


def show_vision_sensors(model: mujoco.MjModel, length: float = FRUSTUM_LENGTH) -> int:
    """Make MuJoCo draw the frustum of every vision sensor of ``model`` (the viewer's copy).

    MuJoCo draws a camera's frustum when the camera has a sensor size (``mjVIS_CAMERA``); a
    simx vision sensor is a camera with a ``resolution`` and a ``fovy``. This gives each such
    camera the sensor size and focal length of the same projection (square pixels, centred),
    so the view through it is unchanged, and sets the frusta's length to ``length`` m.
    Returns the number of vision sensors.
    """
    count = 0
    for i in range(model.ncam):
        width, height = (int(v) for v in model.cam_resolution[i])
        if width <= 1 and height <= 1:
            continue
        count += 1
        if model.cam_sensorsize[i, 1] > 0:
            continue  # the scene gave it a sensor already
        focal = 0.5 / math.tan(math.radians(model.cam_fovy[i]) / 2)  # for a sensor 1 high
        model.cam_sensorsize[i] = (width / height, 1.0)
        model.cam_intrinsic[i] = (focal, focal, 0.0, 0.0)
    model.vis.scale.frustum = length / max(model.stat.meansize, 1e-9)
    return count


class Window:
    """One ``launch_passive`` window on one model; ``close()`` waits for its thread to end."""

    def __init__(self, vm: ViewerModel, args: argparse.Namespace, key_callback,
                 view: tuple | None = None):
        self.model = vm.model
        self.data = mujoco.MjData(self.model)
        vm.state.apply(self.model, self.data)
        show_vision_sensors(self.model)
        mujoco.mj_forward(self.model, self.data)
        framing = default_view(self.model, self.data)  # the scene's objects, unless options say otherwise
        low, high = scene_box(self.model, self.data)
        far_enough(self.model, framing[1], float(np.linalg.norm(high - low)) / 2)  # before the window reads it
        before = set(threading.enumerate())
        self.handle = mujoco.viewer.launch_passive(
            self.model, self.data, key_callback=key_callback,
            show_left_ui=args.ui and not args.hide_ui, show_right_ui=args.ui and not args.hide_ui)
        # launch_passive runs the window in a thread it does not return: joined in close(), or a
        # relaunch or the interpreter's exit would race it (an X error, or a hang, on exit).
        self._threads = [t for t in threading.enumerate() if t not in before]
        with self.handle.lock():
            self.handle.opt.flags[mujoco.mjtVisFlag.mjVIS_CAMERA] = 1
            cam = self.handle.cam
            if view is None:
                cam.lookat[:], cam.distance, cam.azimuth, cam.elevation = framing
            if view is not None:  # the previous window's (a reload): the user's view goes on
                cam.lookat[:], cam.distance, cam.azimuth, cam.elevation = view
            elif args.lookat is not None:
                cam.lookat[:] = args.lookat
            if view is None and args.distance is not None:
                cam.distance = args.distance
            if view is None and args.azimuth is not None:
                cam.azimuth = args.azimuth
            if view is None and args.elevation is not None:
                cam.elevation = args.elevation
        self.handle.sync()

    def running(self) -> bool:
        return self.handle.is_running()

    def view(self) -> tuple:
        """The free camera's lookat, distance, azimuth and elevation now."""
        with self.handle.lock():
            cam = self.handle.cam
            return cam.lookat.copy(), cam.distance, cam.azimuth, cam.elevation

    def close(self) -> None:
        self.handle.close()
        for thread in self._threads:
            thread.join(10)


def run(args: argparse.Namespace) -> int:
    """The viewer's loop; returns the exit status."""
    import mujoco.viewer  # noqa: F401  (GLFW: imported only when a window is wanted)

    paused = threading.Event()

    def on_key(key: int) -> None:
        if key == _SPACE:
            if paused.is_set():
                paused.clear()
            else:
                paused.set()
            log.info("view %s", "paused" if paused.is_set() else "following the server")

    link = ViewerLink(args.host, args.port, args.prefix)
    images = None
    try:
        vm = link.fetch_model(args.timeout)
        view = None
        while True:
            window = Window(vm, args, on_key, view)
            log.info("showing generation %d of %s (%d bodies)", vm.generation, link.address, vm.model.nbody)
            if args.images and images is None:
                from simx_viewer.images import SensorImages
                try:
                    images = SensorImages(args.host, args.port, vm.model)
                except RuntimeError as exc:
                    log.warning("%s", exc)
                    args.images = False
            reload = False
            try:
                while window.running():
                    state = link.next_state(0.05)
                    if images is not None:
                        images.show()
                    if state is None or paused.is_set():
                        continue
                    if state.generation != vm.generation:
                        reload = True
                        view = window.view()
                        break
                    with window.handle.lock():
                        state.apply(window.model, window.data)
                    window.handle.sync()
            finally:
                window.close()
            if not reload:
                return 0
            vm = link.fetch_model(args.timeout)
            if images is not None:
                images.close()
                images = None
    finally:
        if images is not None:
            images.close()
        link.close()


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="simx-viewer",
        description="Watch a running simx-server in MuJoCo's viewer. Space pauses the view.")
    p.add_argument("--host", default="127.0.0.1", help="the server's address (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=19997, help="one of the server's ports (default 19997)")
    p.add_argument("--zenoh-config", metavar="FILE",
                   help="Zenoh config file (TLS, user/password), as $SIMX_ZENOH_CONFIG for simxStart")
    p.add_argument("--prefix", default=P.DEFAULT_PREFIX, help="the server's key prefix (default simx)")
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT,
                   help="s to wait for the server's model (default %(default)s)")
    p.add_argument("--images", action="store_true",
                   help="also show the vision sensors' images (OpenCV windows; needs OpenCV with a GUI)")
    p.add_argument("--ui", action="store_true",
                   help="open with MuJoCo's side panels shown (by default hidden: Tab and Shift+Tab show them)")
    p.add_argument("--hide-ui", action="store_true", help="hide MuJoCo's side panels (the default)")
    p.add_argument("--lookat", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="the point the view orbits, m (default: MuJoCo's, the scene's centre)")
    p.add_argument("--distance", type=float, help="view distance from --lookat, m")
    p.add_argument("--azimuth", type=float, help="view azimuth, degrees")
    p.add_argument("--elevation", type=float, help="view elevation, degrees (negative: from above)")
    return p


def _stop(signum, frame) -> None:
    """SIGTERM: end the viewer's loop as Ctrl-C does (windows closed, the link closed)."""
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Console script ``simx-viewer``; returns the exit status (see the module's docstring)."""
    args = parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    signal.signal(signal.SIGTERM, _stop)  # a clean stop, status 0, as simx-server's
    if args.zenoh_config:
        if not os.path.isfile(args.zenoh_config):
            print(f"simx-viewer: no Zenoh config file {args.zenoh_config}", file=sys.stderr)
            return 2
        os.environ["SIMX_ZENOH_CONFIG"] = args.zenoh_config  # client_config reads it (simxStart too)
    try:
        return run(args)
    except NoServerError as exc:
        print(f"simx-viewer: {exc}. Is simx-server running there? Start one with `simx-server` "
              "or give its address with --host/--port.", file=sys.stderr)
        return 1
    except (P.ProtocolError, P.LocalError, P.RefusedError, RuntimeError) as exc:
        print(f"simx-viewer: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
