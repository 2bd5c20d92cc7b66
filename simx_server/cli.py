"""``simx-server [scene.xml]``: serve a MuJoCo scene over V-REP's legacy remote API."""

from __future__ import annotations

import os

# One BLAS thread for the server's numpy, unless the user set it (before numpy is imported): a
# server is one simulation thread doing small-vector maths (MuJoCo does the heavy part), many
# servers share a machine, and OpenBLAS would start a thread per core in each of them (0.08 s of
# CPU at every start, idle threads spinning after each call).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import faulthandler
import json
import logging
import signal
import sys
import threading
import warnings
from importlib import resources
from pathlib import Path

from simx_server import __version__
from simx_server.base import job_ring, limits
from simx_server.loop import logs, tasks
from simx_server.listen_checks import listen_failure, port_in_use, zmq_port_in_use
from simx_server.scene.formats import SCENE_FILES_TEXT

DEFAULT_SCENE = "ur5_rg2_kinect.xml"
SWITCH_INTERVAL = 0.0005  # s, sys.setswitchinterval (Python's default: 0.005)
STOP_GRACE = 1.5  # s after SIGINT/SIGTERM before the process ends without waiting for a step


def default_scene() -> Path:
    """The bundled UR5 + RG2 + Kinect scene (shipped inside the package)."""
    return Path(str(resources.files("simx_server.scenes") / DEFAULT_SCENE))


def version_text() -> str:
    """``simx-server <version> (MuJoCo <v>, Zenoh <v>, Python <v>)``: what ``--version`` prints.
    The libraries' versions come from their installed metadata (nothing is imported, no GL)."""
    import platform
    from importlib import metadata

    def installed(dist: str) -> str:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return "not installed"

    return (f"simx-server {__version__} (MuJoCo {installed('mujoco')}, Zenoh {installed('eclipse-zenoh')}, "
            f"Python {platform.python_version()})")


class _VersionAction(argparse.Action):
    """``--version``: print :func:`version_text` and exit with status 0 (computed only when asked)."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="print the versions of simx-server, MuJoCo, Zenoh and Python, and exit")

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_text())
        parser.exit(0)


def missing_scene(args: argparse.Namespace) -> str | None:
    """The one line for a scene path that names nothing, or None: the same for serving and for
    ``--list-objects`` (checked here, before MuJoCo, whose "ParseXML: Error opening file" named
    it otherwise)."""
    if args.scene is None or Path(args.scene).exists():
        return None
    where = "--list-objects: " if args.list_objects else ""
    return (f"simx-server: {where}no scene file {args.scene!r} (relative paths start in {Path.cwd()}): give the "
            f"path of {SCENE_FILES_TEXT}, or none for the bundled scene")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="simx-server",
        description="MuJoCo simulation server for V-REP / CoppeliaSim scenes and programs: V-REP's legacy "
                    "remote API over Eclipse Zenoh and CoppeliaSim's ZMQ remote API.",
    )
    p.add_argument("--version", action=_VersionAction)
    p.add_argument("scene", nargs="?", help=f"the scene: {SCENE_FILES_TEXT} (default: the bundled {DEFAULT_SCENE})")
    p.add_argument("--host", action="append", help="address to listen on (repeatable; default 127.0.0.1)")
    p.add_argument("--port", action="append", type=int,
                   help="TCP port to listen on (repeatable; default 19997 and 19999)")
    p.add_argument("--zmq-port", type=int, metavar="N",
                   help="TCP port of CoppeliaSim's ZMQ remote API (coppeliasim-zmqremoteapi-client programs), on "
                        "the --host addresses (default 23000; when that default is taken the server goes on without "
                        "it and says so), and on N+1 (default 23001) the step counter of CoppeliaSim 4.3-4.5's "
                        "client")
    p.add_argument("--no-zmq", action="store_true", help="do not serve the ZMQ remote API")
    p.add_argument("--zmq-curve", metavar="DIR",
                   help="ZMQ remote API with CURVE encryption and client keys: DIR/server.key_secret and "
                        "DIR/clients/*.key (zmq.auth certificates; raw pyzmq clients, docs/SECURITY.md)")
    p.add_argument("--zmq-insecure", action="store_true",
                   help="serve the ZMQ remote API without authentication beside --zenoh-config (off otherwise)")
    p.add_argument("--zenoh-config", metavar="FILE",
                   help="Zenoh config file (endpoints, TLS, authentication); multicast scouting stays off")
    p.add_argument("--dt", type=float, default=None,
                   help="simulation step in s (default: the scene's saved step, a .ttt's own; else 0.05)")
    p.add_argument("--speed", type=float, default=None,
                   help="real-time factor in asynchronous mode; 0 = as fast as possible, as CoppeliaSim headless "
                        "(default: the scene's saved real-time mode, a .ttt's own: its multiplier, or when off "
                        "a pass per 60 Hz display frame, as CoppeliaSim's window; else 1)")
    p.add_argument("--stopped", action="store_true", help="start with the simulation stopped")
    p.add_argument("--pacing", choices=["legacy", "immediate"], default="legacy",
                   help="blocking calls while the simulation runs asynchronously: 'legacy' (default) serves "
                        "a client's next blocking call only after the simulation has stepped since its previous "
                        "one, as V-REP did (once per simulation pass: a joint polled until it stops moving is "
                        "seen moving); 'immediate' serves every call as soon as it arrives (one round trip, "
                        "possibly the same step again) for programs that want raw speed")
    p.add_argument("--renderers", choices=["at-load", "on-demand"], default="at-load",
                   help="when the vision sensors' GL renderers are made: 'at-load' (default), so that the "
                        "first image is as fast as the next; 'on-demand' at the first image instead, which "
                        "then takes 0.5-1 s longer: 0.4-0.5 s of CPU saved at each start of a server whose "
                        "clients read no image")
    p.add_argument("--allow-remote-code", action="store_true",
                   help="let child scripts run code that clients send (Lua load, Python exec); off by default")
    p.add_argument("--allow-unsafe-lua", action="store_true",
                   help="give Lua child scripts files, processes and the environment (io, os.execute, "
                        "os.remove, dofile, package.path...), as CoppeliaSim's executeUnsafe; off by default")
    p.add_argument("--allow-python-scripts", action="store_true",
                   help="run the scenes' Python child and customization scripts, which run with the server's "
                        "rights (files, processes, network); off by default: each is refused with one log line "
                        "and the scene loads with its Lua scripts")
    p.add_argument("--scene-path", action="append", metavar="DIR", default=[],
                   help="folder clients may load server-side scenes and models from (simxLoadScene/"
                        "simxLoadModel with options 0), besides the scene's folder (repeatable)")
    p.add_argument("--prefix", default="simx", help="Zenoh key-expression prefix (default simx)")
    p.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    p.add_argument("--log-interval", type=float, default=limits.LOG_REPEAT_INTERVAL, metavar="S",
                   help=f"repeated log lines: {limits.LOG_REPEAT_BURST} of a kind per interval, then one "
                        f"summary line at its end (default {limits.LOG_REPEAT_INTERVAL:g} s)")
    p.add_argument("--client-expiry", type=float, default=limits.CLIENT_EXPIRY, metavar="S",
                   help="drop the state of a client without liveliness token after this many s without "
                        f"a request (default {limits.CLIENT_EXPIRY:g})")
    p.add_argument("--instances", type=int, default=1, metavar="N",
                   help="run N servers, each its own process and simulation on a port of its own: on free "
                        "ports, or with --port P on P, P+1, ..., P+N-1 (one --host, one --port at most); "
                        "one ready line lists them all, SIGINT/SIGTERM stops them all (default 1)")
    p.add_argument("--log-dir", metavar="DIR",
                   help="with --instances: folder for the servers' logs server-<i>.log (default: a temporary "
                        "folder removed when they stop)")
    p.add_argument("--list-objects", action="store_true",
                   help="print the scene's V-REP objects as V-REP's scene hierarchy shows them (handle, type, "
                        "name, joint modes, sensor settings, child scripts) and exit, without serving it")
    p.add_argument("--json", action="store_true", help="with --list-objects: print JSON instead of text")
    p.add_argument("--urdf-to-mjcf", metavar="OUT",
                   help="convert the URDF scene to the MJCF file OUT as simx loads it (links as shapes, joint "
                        "motors as simx: texts) and exit; add cameras, actuators and simx: texts to OUT")
    return p.parse_args(argv)


def argument_error(args: argparse.Namespace) -> str | None:
    """The line that refuses ``args`` before anything loads (a port out of range, a folder given
    as the scene), or None when they are usable."""
    for port in args.port or ():
        if not 0 < port <= 65535:
            return f"simx-server: --port {port}: a TCP port is a number from 1 to 65535"
    if args.zmq_port is not None and not 0 < args.zmq_port <= 65535:
        return f"simx-server: --zmq-port {args.zmq_port}: a TCP port is a number from 1 to 65535"
    if args.zmq_curve and args.zmq_insecure:
        return "simx-server: --zmq-curve and --zmq-insecure exclude each other"
    if args.zenoh_config and args.zmq_port is not None and not (args.zmq_curve or args.zmq_insecure or args.no_zmq):
        return ("simx-server: --zmq-port with --zenoh-config: the ZMQ remote API has no authentication of its own; "
                "add --zmq-curve DIR (CURVE keys) or --zmq-insecure (docs/SECURITY.md)")
    if args.scene and Path(args.scene).is_dir():
        return f"simx-server: {args.scene} is a folder, not a scene file: give {SCENE_FILES_TEXT}"
    if args.scene and Path(args.scene).exists() and not Path(args.scene).is_file():  # reading a FIFO waits for good
        return f"simx-server: {args.scene} is not a regular file (a FIFO, socket or device): give {SCENE_FILES_TEXT}"
    return missing_scene(args)


def _warnings_to_log() -> None:
    """Python warnings (MuJoCo's, such as a deprecated compiler attribute, raised at each compile)
    as one log line each, once per text, in the log's format rather than with a source line."""
    warnings.filterwarnings("once", category=UserWarning)

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        logging.getLogger("simx.mujoco").warning("%s", message)

    warnings.showwarning = show


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``simx-server`` console script; returns the exit code."""
    args = parse_args(argv)
    if args.json and not args.list_objects:
        print("simx-server: --json goes with --list-objects", file=sys.stderr)
        return 2
    refused = argument_error(args)
    if refused:
        print(refused, file=sys.stderr)
        return 2
    _warnings_to_log()
    if args.list_objects:  # inspect the scene and exit: no Zenoh, no rendering
        from simx_server.scene.listing import main as list_objects

        try:
            return list_objects(args.scene or default_scene(), as_json=args.json, dt=args.dt)  # None: the scene's
        except BrokenPipeError:  # `simx-server --list-objects | head`: the reader has enough
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit's flush
            return 0
    if args.urdf_to_mjcf:
        from simx_server.sim.urdf import main_to_mjcf

        return main_to_mjcf(args.scene, args.urdf_to_mjcf)
    if args.instances != 1 or args.log_dir is not None:
        return run_instances(args)
    logging.basicConfig(level=args.log_level, stream=sys.stderr,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    logging.getLogger("OpenGL").setLevel(logging.WARNING)
    if not (args.log_interval > 0 and args.client_expiry > 0):
        print("simx-server: --log-interval and --client-expiry must be > 0", file=sys.stderr)
        return 2
    logs.install(interval=args.log_interval)  # repeated lines: a few, then a count
    # Zenoh's threads (one client's flood) and the simulation thread take turns at the GIL:
    # hand it over every 0.5 ms rather than 5, so a waiting request is not held up for long.
    sys.setswitchinterval(SWITCH_INTERVAL)
    from simx_server.legacy.allocator import tune_malloc

    tune_malloc()  # freed memory goes back to the system (before Zenoh's and the render threads start)
    os.environ.setdefault("MUJOCO_GL", "egl")
    # Zenoh's config and the ports first (Zenoh and the config module: about 0.05 s), so that a
    # taken port is said at once, before MuJoCo, OpenCV and the API table load (1-1.5 s).
    import zenoh

    from simx_server.legacy.zenoh_config import DEFAULT_HOSTS, DEFAULT_PORTS, zenoh_config

    for folder in args.scene_path:
        if not Path(folder).is_dir():
            print(f"simx-server: --scene-path {folder}: not a folder", file=sys.stderr)
            return 2
    endpoints = [f"tcp/{h}:{p}" for h in (args.host or DEFAULT_HOSTS) for p in (args.port or DEFAULT_PORTS)]
    try:
        config = zenoh_config(endpoints, args.zenoh_config)
        endpoints = json.loads(config.get_json("listen/endpoints"))
    except (zenoh.ZError, ValueError, OSError) as exc:
        print(listen_failure(endpoints, exc), file=sys.stderr)
        return 2
    taken = port_in_use(endpoints) or zmq_port_in_use(args)  # said now, not after the scene has loaded
    if taken:
        print(taken, file=sys.stderr)
        return 2
    # Imported here so that --help and the refusals above work without a GL stack, at once.
    from simx_server.scene.simulation import Simulation
    from simx_server.legacy.script_hooks import ScriptHooks
    from simx_server.legacy.server import Server

    scene = Path(args.scene) if args.scene else default_scene()
    try:
        sim = Simulation(scene, dt=args.dt, realtime=None if args.speed is None else args.speed > 0,
                         allow_remote_code=args.allow_remote_code, allow_unsafe_lua=args.allow_unsafe_lua,
                         scene_paths=args.scene_path, renderers_at_load=args.renderers == "at-load",
                         allow_python_scripts=args.allow_python_scripts)
    except (ValueError, OSError) as exc:
        print(f"simx-server: {exc}", file=sys.stderr)
        return 2
    speed = sim.speed(args.speed)
    try:
        server = Server(sim, config, speed=speed, prefix=args.prefix, client_expiry=args.client_expiry,
                        pacing=args.pacing)
        server.open()
        server.attach(ScriptHooks(sim, config))  # simExtRemoteApiStart(port) in the scene's scripts
        tasks.attach(server.loop, sim)  # .ttt/.ttm loads: converted off the simulation thread, then loaded
    except (zenoh.ZError, ValueError, OSError) as exc:
        print(listen_failure(endpoints, exc), file=sys.stderr)
        sim.close()
        return 2

    def stop(signum, frame):
        server.request_stop()

    zmq_line = _attach_zmq(server, args)
    if zmq_line is None:
        server.close()
        return 2
    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    # `kill -USR1 <pid>` writes every thread's stack to the log (stderr): what a server that
    # stopped answering is doing (simx_client.envs names it when a call times out).
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    served = threading.Event()
    _watch_signals(server, served)
    sim.vision.wait_ready(limits.VISION_READY_TIMEOUT)  # the renderers exist before the first request
    if not args.stopped:
        sim.start()
    print(f"simx-server ready: scene {scene.name}, {len(sim.world.objects)} objects, "
          f"{sim.pacing_text(args.dt, args.speed)}, listening on {', '.join(endpoints)}{zmq_line}", flush=True)
    try:
        server.serve()
    finally:
        served.set()
        server.close()
        # A planner's job thread that is ending still holds its OMPL objects: let it end first
        # (a daemon thread alive at exit keeps them, and OMPL's bindings print "leaked" lines).
        job_ring.settle_all(limits.JOBS_SETTLE_TIMEOUT)
        logging.getLogger("simx.server").info("stopped")
    return 0


def _attach_zmq(server, args: argparse.Namespace) -> str | None:
    """Serve the ZMQ remote API from ``server`` unless ``--no-zmq``: the ready line's part about
    it, or None after printing why it cannot listen (an explicit ``--zmq-port`` in use). The
    default port taken (another simx-server has it) is logged, and the server goes on without."""
    if args.no_zmq:
        return ""
    log = logging.getLogger("simx.zmq")
    if args.zenoh_config and not (args.zmq_curve or args.zmq_insecure):
        log.warning("ZMQ remote API off: --zenoh-config secures the Zenoh side and ZMQ has no authentication of "
                    "its own; serve it with --zmq-curve DIR (CURVE keys) or --zmq-insecure (docs/SECURITY.md)")
        return ", no ZMQ remote API (--zenoh-config: add --zmq-curve DIR or --zmq-insecure)"
    import zmq

    from simx_server.legacy.server import DEFAULT_HOSTS
    from simx_server.zmq.remote_api import DEFAULT_PORT, ZmqRemoteApi, curve_keys, endpoints

    curve = None
    if args.zmq_curve:
        try:
            curve = curve_keys(args.zmq_curve)
        except ValueError as exc:
            print(f"simx-server: --zmq-curve: {exc}", file=sys.stderr)
            return None
    elif args.zmq_insecure and args.zenoh_config:
        log.warning("ZMQ remote API without authentication (--zmq-insecure): whoever reaches its port runs the "
                    "simulation, around --zenoh-config's TLS, passwords and access control (docs/SECURITY.md)")
    port = args.zmq_port if args.zmq_port is not None else DEFAULT_PORT
    api = ZmqRemoteApi(server.loop, endpoints(args.host or list(DEFAULT_HOSTS), port), curve)
    try:
        api.open()
    except zmq.ZMQError as exc:
        where = ", ".join(api.frontend.endpoints)
        if args.zmq_port is None and exc.errno == zmq.EADDRINUSE:
            log.warning(
                "ZMQ remote API not served: port %d is in use (another simx-server?); choose one with "
                "--zmq-port N, or --no-zmq", port)
            return ", no ZMQ remote API (port in use)"
        print(f"simx-server: cannot listen on {where} (ZMQ remote API): {exc.strerror}; choose a free port with "
              "--zmq-port N, or --no-zmq", file=sys.stderr)
        return None
    server.attach(api)
    pace = f"a running pass serves its requests {limits.ZMQ_PASS_WINDOW * 1000:g} ms per client, as CoppeliaSim's"
    return f"; ZMQ remote API on {', '.join(api.bound)} ({pace})"


def _child_args(args: argparse.Namespace) -> list[str]:
    """The arguments each server of ``--instances`` gets (all but host, port and instances)."""
    out = [args.scene] if args.scene else []
    if args.zenoh_config:
        out += ["--zenoh-config", args.zenoh_config]
    for flag, value in (("--dt", args.dt), ("--speed", args.speed)):
        if value is not None:  # else each server takes the scene's own
            out += [flag, repr(value)]
    out += ["--pacing", args.pacing,
            "--prefix", args.prefix, "--log-level", args.log_level, "--log-interval", repr(args.log_interval),
            "--client-expiry", repr(args.client_expiry), "--renderers", args.renderers]
    for folder in args.scene_path:
        out += ["--scene-path", folder]
    out.append("--no-zmq")  # one ZMQ port cannot serve N servers
    for flag in ("stopped", "allow_remote_code", "allow_unsafe_lua", "allow_python_scripts"):
        if getattr(args, flag):
            out.append("--" + flag.replace("_", "-"))
    return out


def run_instances(args: argparse.Namespace) -> int:
    """``simx-server --instances N``: N servers (a :class:`~simx_server.pool.ServerPool`) under this
    process, which prints one ready line with every endpoint and stops them all on SIGINT/SIGTERM
    (or when one of them exits: then it stops the others and exits with status 1)."""
    from simx_server.pool import PoolError, ServerPool

    n = args.instances
    if n < 1:
        print(f"simx-server: --instances must be >= 1, got {n}", file=sys.stderr)
        return 2
    if len(args.host or []) > 1 or len(args.port or []) > 1:
        print("simx-server: with --instances give at most one --host and one --port (the first of N "
              "consecutive ports)", file=sys.stderr)
        return 2
    host = (args.host or ["127.0.0.1"])[0]
    ports = None
    if args.port:
        first = args.port[0]
        if not (0 < first and first + n - 1 <= 65535):
            print(f"simx-server: --port {first} with --instances {n}: ports {first}..{first + n - 1} are not "
                  f"all valid", file=sys.stderr)
            return 2
        ports = list(range(first, first + n))
    if args.log_dir is not None:
        Path(args.log_dir).mkdir(parents=True, exist_ok=True)
    stop = threading.Event()

    def on_signal(signum, frame):
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    try:
        pool = ServerPool(n, None, *_child_args(args), host=host, ports=ports, log_dir=args.log_dir)
    except PoolError as exc:
        print(f"simx-server: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 0
    signal.signal(signal.SIGINT, on_signal)
    try:
        endpoints = ", ".join(f"tcp/{h}:{p}" for h, p in pool.addresses)
        scene = Path(args.scene).name if args.scene else DEFAULT_SCENE
        print(f"simx-server ready: {n} instances of scene {scene}, listening on {endpoints}", flush=True)
        if args.log_dir is not None:
            print(f"simx-server: logs in {', '.join(map(str, pool.log_paths))}", file=sys.stderr, flush=True)
        while not stop.wait(0.2):
            failed = [(i, rc) for i, rc in enumerate(pool.poll()) if rc is not None]
            if failed:
                i, rc = failed[0]
                print(f"simx-server: instance {i} (port {pool.ports[i]}) exited with status {rc}; stopping "
                      f"the others. Its log:\n{pool.logs()[i][-4000:]}", file=sys.stderr, flush=True)
                return 1
        return 0
    finally:
        pool.close()


def _watch_signals(server, served: threading.Event) -> None:
    """Stop within STOP_GRACE s of SIGINT/SIGTERM even while a long simulation step runs.

    Python runs a signal handler on the main thread only between two bytecodes, that is after
    the step in progress (MuJoCo releases the GIL while it steps, but holds the main thread).
    The C-level handler also writes the signal's number to a wake-up socket at once; a thread
    waiting on it asks the loop to stop and, if the loop has not returned after the grace
    period, ends the process without waiting for the step.
    """
    import socket

    ours = {signal.SIGINT, signal.SIGTERM}
    reader, writer = socket.socketpair()
    writer.setblocking(False)
    signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)

    def watch() -> None:
        keep = writer  # the wake-up socket lives as long as this thread  # noqa: F841
        while True:
            data = reader.recv(16)
            if not data:
                return
            if not ours.intersection(data):
                continue
            server.request_stop()
            if not served.wait(STOP_GRACE):
                logging.getLogger("simx.server").error(
                    "stopping: the simulation step still runs %g s after the signal; exiting without waiting for it",
                    STOP_GRACE)
                try:  # the transfer folder goes as on a normal stop (only kill -9 leaves one behind)
                    server.sim.editor.close()
                except Exception:
                    pass
                logging.shutdown()
                os._exit(0)
            return

    threading.Thread(target=watch, name="simx-signals", daemon=True).start()


if __name__ == "__main__":
    sys.exit(main())
