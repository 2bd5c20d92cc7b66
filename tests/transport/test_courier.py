"""The courier (simx_server/transport/courier.py): replies and stream updates leave on one
sending thread, in order per client lane, each once its renders are done; a lane waiting for a
render holds up no other lane (issue 23: sends to a stopped client held the simulation thread)."""

from __future__ import annotations

import threading
from concurrent.futures import Future

from conftest import wait_until
from simx_server.transport.courier import Courier


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
