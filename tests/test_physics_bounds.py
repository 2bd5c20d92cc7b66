"""Issue 11, physics side: bounded work per step, physical ranges, blow-ups without a flood.

Reproductions of the issue (real servers on loopback) and unit checks of the bounds
(in-process ``Simulation``/``World``). Bounds live in ``simx_server.limits``.
"""

from __future__ import annotations

import pytest

from conftest import SCENE
from simx_client.protocol import ArgumentError
from simx_server import commands, limits
from simx_server.script_facade import Signals
from simx_server.simulation import Simulation


@pytest.fixture(scope="module")
def sim():
    s = Simulation(SCENE)
    yield s
    s.close()


# ------------------------------------------------------------- signal store
def test_signal_store_is_bounded():
    s = Signals(max_signals=3, max_bytes=10, max_store_bytes=40, max_name=8)
    s.set(Signals.INT, "a", 1)
    s.set(Signals.FLOAT, "b", 2.0)
    s.set(Signals.STRING, "c", b"0123456789")  # 10 bytes: the most
    with pytest.raises(ArgumentError, match="MAX_SIGNALS"):
        s.set(Signals.INT, "d", 4)
    s.set(Signals.INT, "a", 5)  # replacing one is fine
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_BYTES"):
        s.set(Signals.STRING, "c", b"0123456789x")
    assert s.get(Signals.STRING, "c") == b"0123456789"  # unchanged
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_NAME"):
        s.set(Signals.INT, "x" * 9, 1)
    s.clear(Signals.INT, "a")
    s.set(Signals.STRING, "long", b"0123456789")
    assert (s.count, s.size) == (3, 9 + 11 + 14)  # a name's characters + 8 bytes a number
    s.clear(Signals.FLOAT, "b")
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_STORE_BYTES"):
        s.set(Signals.STRING, "bigger", b"0123456789")  # 16 more bytes: 41 > 40
    assert (s.count, s.size) == (2, 11 + 14)
    s.clear()
    assert (s.count, s.size) == (0, 0)
    s.set(Signals.STRING, "e", "é" * 5, by_script=True)  # 10 bytes in UTF-8
    s.clear_script_signals()
    assert (s.count, s.size) == (0, 0)


def test_appending_to_a_string_signal_stops_at_the_bound(sim):
    """simxAppendStringSignal grew one signal without end (each append copying it whole)."""
    chunk = b"x" * (1 << 20)
    for _ in range(limits.MAX_SIGNAL_BYTES >> 20):
        commands.append_string_signal(sim, ["stream", chunk])
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_BYTES"):
        commands.append_string_signal(sim, ["stream", b"y"])
    assert len(sim.signals.get(Signals.STRING, "stream")) == limits.MAX_SIGNAL_BYTES
    sim.signals.clear(Signals.STRING, "stream")
    assert sim.signals.size == 0
