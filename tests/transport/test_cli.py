"""simx-server as a process: ready line, clean exits, clear errors."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest

import vrep
from conftest import ROOT, ServerProcess, free_port, ready_line, wait_until
from simx_server.cli import STOP_GRACE


def test_bad_scene_exits_nonzero_with_mujoco_message(tmp_path):
    bad = tmp_path / "broken.xml"
    bad.write_text("<mujoco><worldbody><geom type='sphere'/></worldbody>")  # unclosed root
    out = subprocess.run([sys.executable, "-m", "simx_server.cli", str(bad), "--port", str(free_port())],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode != 0
    assert "broken.xml" in out.stderr
    assert "XML" in out.stderr or "Error" in out.stderr  # MuJoCo's own parser message


def test_missing_scene_exits_nonzero(tmp_path):
    out = subprocess.run([sys.executable, "-m", "simx_server.cli", str(tmp_path / "nope.xml"),
                          "--port", str(free_port())], capture_output=True, text=True, timeout=60)
    assert out.returncode != 0 and "nope.xml" in out.stderr


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_default_scene_serves_then_exits_within_2_s(sig):
    srv = ServerProcess(renderers="on-demand")  # no scene argument: the bundled UR5 scene
    try:
        assert "ur5_rg2_kinect.xml" in srv.ready_line
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        assert vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)[0] == 0
        vrep.simxFinish(cid)

        def log() -> str:  # read through a descriptor of its own: the server shares the log's offset
            with open(f"/proc/self/fd/{srv.log.fileno()}") as f:
                return f.read()

        # the Bye is served on the simulation thread: the signal must not overtake it
        wait_until(lambda: "disconnected" in log(), what="the client's Bye served")
        srv.proc.send_signal(sig)
        code = srv.proc.wait(timeout=30)  # a bound on the wait only: a hang fails here
        assert code == 0, f"exit status {code}; the server's log:\n{log()[-4000:]}"
    finally:
        err = srv.stop()
    assert "connected" in err and "disconnected" in err  # connect and leave are logged
    # The 2 s are the server's own guarantee, kept by its timer (cli.STOP_GRACE), not measured
    # here: an idle server stops by the normal path ("stopped", after closing), never by that
    # timer's forced exit.
    assert STOP_GRACE < 2.0
    assert err.rstrip().endswith("stopped") and "exiting without waiting" not in err, err[-2000:]


def test_the_built_wheel_installs_a_server_and_client_that_work(tmp_path):
    """What ``pip install <checkout>`` gives a user (not the editable install the suite runs on):
    the wheel is built, installed into a fresh environment, its ``simx-server`` serves the bundled
    scene and a legacy program run by that environment's Python talks to it (issue 49: a wheel
    that lacked ``simx_server.api`` installed fine and then could not start)."""
    # Built from a copy of the checkout's files (tracked, or untracked and not ignored), as a fresh
    # clone has them: setuptools would otherwise reuse a build/ folder an earlier build left.
    source = tmp_path / "source"
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT, capture_output=True,
                           check=True).stdout.decode().split("\0")
    for name in filter(None, files):
        if (ROOT / name).is_file():
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, source / name)
    # --no-build-isolation: the test extra's setuptools builds it, nothing is downloaded
    out = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                          "-w", str(tmp_path), str(source)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    (wheel,) = tmp_path.glob("simx-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for required in ("simx_server/scenes/ur5_rg2_kinect.xml", "simx_server/scenes/rg2.lua", "vrep.py", "sim.py",
                     "simx_server/zmq/coppeliasim_api.json", "pyrep/assets/empty.xml"):
        assert required in names, f"{required} missing from the wheel"
    # Every package of the checkout is in the wheel: a package missing from it is what broke.
    packages = {p.parent.relative_to(ROOT).as_posix() for top in ("simx_wire", "simx_client", "simx_server", "simx_viewer",
                                                                       "pyrep")
                for p in (ROOT / top).rglob("__init__.py")}
    assert {p for p in packages if f"{p}/__init__.py" not in names} == set()

    # A fresh environment with the wheel alone; its dependencies come from the test environment's
    # site-packages through .pth lines (plain paths: the editable install's finder there is not run).
    env_dir = tmp_path / "fresh"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True, timeout=120)
    python = env_dir / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                          capture_output=True, text=True, check=True).stdout.strip()
    deps = next(p for p in map(Path, sys.path) if p.name == "site-packages" and (p / "mujoco").is_dir())
    # coal (exact collision queries) is a cmeel package: its modules live in a prefix of their own
    # that its cmeel.pth adds; a plain path line runs no .pth of that folder, so it is named too
    cmeel = sorted(deps.glob("cmeel.prefix/lib/python*/site-packages"))
    (Path(site) / "simx-test-deps.pth").write_text("".join(f"{p}\n" for p in (deps, *cmeel)))
    out = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index",
                          "-q", str(wheel)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    where = subprocess.run([str(python), "-c", "import simx_server; print(simx_server.__file__)"],
                           capture_output=True, text=True, cwd=tmp_path, check=True).stdout
    assert where.startswith(site), where  # the wheel's copy, not the checkout
    # PyRep's interface from the wheel: its empty scene (package data) launches and steps
    pyrep = subprocess.run([str(python), "-c", "import pyrep; p = pyrep.PyRep(); p.launch(''); p.start(); p.step(); "
                            "print(p.get_simulation_timestep() > 0, pyrep.__file__); p.shutdown()"],
                           capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ, MUJOCO_GL="egl"),
                           timeout=120)
    assert pyrep.returncode == 0, pyrep.stderr[-3000:]
    stepped, module = pyrep.stdout.split()
    assert stepped == "True" and module.startswith(site)

    port = free_port()
    env = dict(os.environ, MUJOCO_GL="egl", PYTHONUNBUFFERED="1")
    with tempfile.TemporaryFile(mode="w+") as log:
        server = subprocess.Popen([str(env_dir / "bin" / "simx-server"), "--port", str(port), "--no-zmq",
                                   "--renderers", "on-demand"], stdout=subprocess.PIPE, stderr=log, text=True,
                                  cwd=tmp_path, env=env)
        try:
            line = ready_line(server, timeout=60)
            log.seek(0)
            assert line is not None and "ur5_rg2_kinect.xml" in line, log.read()[-3000:]
            program = ("import vrep\n"
                       f"cid = vrep.simxStart('127.0.0.1', {port}, True, True, 5000, 5)\n"
                       "rc, h = vrep.simxGetObjectHandle(cid, 'UR5_joint1', vrep.simx_opmode_blocking)\n"
                       "print(cid >= 0, rc, h > 0, vrep.__file__)\n"
                       "vrep.simxFinish(cid)\n")
            out = subprocess.run([str(python), "-c", program], capture_output=True, text=True, cwd=tmp_path,
                                 env=env, timeout=120)
            assert out.returncode == 0, out.stderr
            ok, rc, handle, module = out.stdout.split()
            assert (ok, rc, handle) == ("True", "0", "True") and module.startswith(site)
        finally:
            server.terminate()
            server.wait(timeout=30)


def test_zenoh_config_file_sets_the_endpoints(tmp_path):
    port = free_port()
    config = tmp_path / "zenoh.json5"
    config.write_text('{ listen: { endpoints: ["tcp/127.0.0.1:%d"] }, scouting: { multicast: { enabled: false } } }' % port)
    proc = subprocess.Popen([sys.executable, "-m", "simx_server.cli", "--zenoh-config", str(config)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert f"tcp/127.0.0.1:{port}" in line and "19997" not in line
        cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
        assert cid >= 0 and vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)[0] == 0
        vrep.simxFinish(cid)
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_client_program_exits_promptly_without_finish(tmp_path):
    """A legacy program that never calls simxFinish still ends at once (no hang at exit)."""
    srv = ServerProcess(renderers="on-demand")
    try:
        script = tmp_path / "forgetful.py"
        script.write_text(
            "import vrep\n"
            f"cid = vrep.simxStart('127.0.0.1', {srv.port}, True, True, 5000, 5)\n"
            "assert cid >= 0\n"
            "rc, h = vrep.simxGetObjectHandle(cid, 'UR5_joint1', vrep.simx_opmode_blocking)\n"
            "vrep.simxGetJointPosition(cid, h, vrep.simx_opmode_streaming)\n"
            "print('done', rc)\n")
        try:  # the timeout bounds the wait only: a program held up at exit fails here
            out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=60)
        except subprocess.TimeoutExpired:
            pytest.fail("the program did not exit: something it left open (a Zenoh session, a thread) "
                        "holds up interpreter exit")
        assert out.returncode == 0 and "done 0" in out.stdout, out.stderr
    finally:
        srv.stop()


def test_instances_get_the_renderers_option():
    """``--instances N --renderers on-demand``: each server of the pool is started with it."""
    from simx_server.cli import _child_args, parse_args

    args = _child_args(parse_args(["--instances", "2", "--renderers", "on-demand"]))
    assert args[args.index("--renderers") + 1] == "on-demand"
    args = _child_args(parse_args(["--instances", "2"]))
    assert args[args.index("--renderers") + 1] == "at-load"  # the default, as a single server's
