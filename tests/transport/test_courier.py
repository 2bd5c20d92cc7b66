"""The courier (simx_server/loop/courier.py): replies and stream updates leave on one
sending thread, in order per client lane, each once its renders are done; a lane waiting for a
render holds up no other lane (issue 23: sends to a stopped client held the simulation thread)."""

from __future__ import annotations

import threading
from concurrent.futures import Future

from conftest import wait_until
from simx_server.loop.courier import Courier


def test_a_lane_keeps_its_order_and_waits_for_its_renders_without_holding_other_lanes():
    courier = Courier()
    sent: list[str] = []
    done = threading.Event()
    frame: Future = Future()  # a render still in progress
    try:
        courier.send("a", lambda: sent.append("a1"), [frame])
        courier.send("a", lambda: sent.append("a2"))  # no render of its own: still after a1
        courier.send("b", lambda: sent.append("b1"))
        courier.send("b", lambda: (sent.append("b2"), done.set()))
        assert done.wait(5), "lane b waited for lane a's render"
        assert sent == ["b1", "b2"] and courier.pending() == 1
        frame.set_result(None)  # the render thread finishes: lane a goes on, in order
        wait_until(lambda: not courier.pending(), timeout=5, what="lane a sent")
        assert sent == ["b1", "b2", "a1", "a2"]
    finally:
        courier.close()


def test_a_failing_send_is_logged_and_the_lane_goes_on(caplog):
    courier = Courier()
    sent = []

    def broken() -> None:
        raise RuntimeError("link gone")

    try:
        courier.send("a", broken)
        courier.send("a", lambda: sent.append("after"))
    finally:
        courier.close()  # waits for the sends handed over
    assert sent == ["after"]
    assert "sending to a" in caplog.text and "link gone" in caplog.text


def test_after_close_a_send_runs_on_the_callers_thread():
    courier = Courier()
    courier.close()
    where = []
    courier.send("a", lambda: where.append(threading.current_thread()))
    assert where == [threading.current_thread()]


def test_a_bulk_send_gives_way_to_other_lanes_and_keeps_its_lanes_order():
    """A send of images of limits.BULK_SEND_BYTES or more (a 4096x4096 stream update: tens of ms
    to push) goes after the other lanes' sends that are ready, and its own lane stays behind it."""
    courier = Courier()
    sent: list[str] = []
    gate = threading.Event()
    try:
        courier.send("x", gate.wait)  # holds the sending thread while the others are handed over
        courier.send("a", lambda: sent.append("a-bulk"), bulk=True)
        courier.send("a", lambda: sent.append("a-small"))
        courier.send("b", lambda: sent.append("b1"))
        courier.send("c", lambda: sent.append("c1"))
        courier.send("b", lambda: sent.append("b2"))
        gate.set()
        wait_until(lambda: not courier.pending(), timeout=5, what="every lane sent")
        assert sent == ["b1", "b2", "c1", "a-bulk", "a-small"]  # a lane is pumped until empty
    finally:
        gate.set()
        courier.close()


def test_a_bulk_send_waits_at_most_max_bulk_defer_seconds(monkeypatch):
    """Other clients' sends that never stop coming do not starve a bulk send."""
    from simx_server.base import limits

    monkeypatch.setattr(limits, "MAX_BULK_DEFER_SECONDS", 0.2)
    courier = Courier()
    sent: list[str] = []
    stop = threading.Event()

    def feed() -> None:  # small sends on many lanes, one ready at every moment
        k = 0
        while not stop.is_set() and k < 20_000:
            courier.send(f"small{k % 8}", lambda: stop.wait(0.001))
            k += 1
            stop.wait(0.0005)

    feeder = threading.Thread(target=feed)
    try:
        feeder.start()
        wait_until(lambda: courier.pending() > 2, timeout=5, what="small sends queued")
        courier.send("big", lambda: sent.append("bulk"), bulk=True)
        wait_until(lambda: sent, timeout=3, what="the bulk send despite the small ones")
        assert feeder.is_alive(), "the small sends had stopped: the bound was not what sent it"
    finally:
        stop.set()
        feeder.join()
        courier.close()
