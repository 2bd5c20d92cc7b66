"""V-REP's scripts as scenes carry them (issue 34), in-process: the first-line comment that Lua's
``loadfile`` skips, pre-3.6 ``sim_call_type`` scripts, the 3.x global names, threaded scripts as
coroutines, customization scripts, joint callbacks and script simulation parameters.

Each test writes a small scene and its scripts into ``tmp_path`` and drives a
:class:`~simx_server.scene.simulation.Simulation` step by step (no wall clock, no network).
"""

from __future__ import annotations

import logging

import pytest

from test_scripts import call, small_scene
from simx_server.scene.simulation import Simulation


@pytest.fixture
def run(tmp_path):
    sims = []

    def make(scripts: dict, settings: str = "", **kwargs) -> Simulation:
        sim = Simulation(small_scene(tmp_path, scripts, settings), realtime=False, **kwargs)
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()


# ---------------------------------------------------------------- loading
def test_a_first_line_starting_with_hash_is_skipped_as_loadfile_does(run):
    source = "#!/usr/bin/env lua -- a comment line some authors write\nfunction f(a, b, c, d)\n" \
             "  error('here')\nend\nfunction g() return {7} end\n"
    sim = run({"Box": ("hash.lua", source)})
    assert sim.scripts.scripts[next(iter(sim.scripts.scripts))].load_error is None
    sim.start()
    assert call(sim, "Box", "g") == [[7], [], [], b""]
    with pytest.raises(Exception, match=r"hash\.lua:3: here"):  # line numbers stay those of the file
        call(sim, "Box", "f")
