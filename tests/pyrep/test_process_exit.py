"""A PyRep program that ends without ``shutdown()`` (its last line run, an uncaught error,
``sys.exit``) exits quietly. Its renderers are still open then, and the garbage collector of
the ending interpreter called ``mujoco.Renderer.__del__`` on the main thread: ``close()`` freed
GL objects with no current context and imported OpenGL after imports had stopped ("Exception
ignored in ... Renderer.__del__ ... ImportError: sys.meta_path is None, Python is likely
shutting down")."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import PYREP_SCENE

ROOT = Path(__file__).resolve().parents[2]

PROGRAM = """
import sys
from pyrep import PyRep
from pyrep.objects.vision_sensor import VisionSensor
pr = PyRep()
pr.launch(sys.argv[1], headless=True)
pr.start()
cam = VisionSensor("cam")
pr.step()
print("image", cam.capture_rgb().shape, flush=True)
"""


@pytest.mark.parametrize("look", ["mujoco", "vrep"])
def test_a_program_that_never_shuts_down_exits_without_a_traceback(tmp_path, look):
    custom = f'<custom><text name="simx:scene:vision" data="look={look}"/></custom>'
    scene = tmp_path / "small.xml"
    scene.write_text(PYREP_SCENE.replace("</mujoco>", custom + "\n</mujoco>"))
    env = dict(os.environ, MUJOCO_GL="egl", PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", PROGRAM, str(scene)], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "image (24, 32, 3)" in done.stdout
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr[-2000:]
