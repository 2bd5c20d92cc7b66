"""Issue 40: a .ttt's script with CoppeliaSim's python marker (``Lne``) becomes a ``.py`` file of the
converted scene, which runs only on a server started with ``--allow-python-scripts``
(tests/scripts/test_python_consent.py has the rest); the scene's Lua script runs either way."""

from __future__ import annotations

import logging

import pytest

import tttwriter as W

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

PY = "#python\nimport os\n\ndef sysCall_init():\n    sim.setInt32Signal('py', 1)\n"
LUA = "function sysCall_init() sim.setInt32Signal('lua', 1) end"


@pytest.mark.parametrize("allowed", [False, True])
def test_a_ttt_scenes_python_script_runs_only_with_the_flag(tmp_path, monkeypatch, caplog, allowed):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation

    (tmp_path / "mixed.ttt").write_bytes(W.ttt_file(
        W.dummy(1, -1, "Lua") + W.dummy(2, -1, "Py") + W.script(100, 1, LUA)
        + W.script(101, 2, PY, language="python"), serialization=24, program=40600))
    with caplog.at_level(logging.ERROR, "simx.scripts"):
        sim = Simulation(tmp_path / "mixed.ttt", realtime=False, allow_python_scripts=allowed)
        try:
            sim.start()
            got = sim.signals.get_int("lua"), sim.signals.get_int("py")
        finally:
            sim.close()
    assert got == (1, 1 if allowed else None)
    refused = [r.getMessage() for r in caplog.records if "--allow-python-scripts" in r.getMessage()]
    assert len(refused) == (0 if allowed else 1) and all("of 'Py'" in m for m in refused), refused
