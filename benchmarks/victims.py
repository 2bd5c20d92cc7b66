"""Attacks on a server while another client loops a cheap call: the other client's slowest call
(the "gap") is the figure (benchmarks.robustness_long_calls, benchmarks.robustness_meshes)."""

from __future__ import annotations

import math
import threading
import time

import zmq

from benchmarks.robustness_zmq import Target, _short, call


def during(t: Target, ctx: zmq.Context, attackers: int, attack, before=None) -> tuple[str, str]:
    """``attackers`` connections (uuids a0, a1...) each run ``attack(socket, uuid)`` at once while
    another client loops ``sim.getSimulationTime``: its slowest call (and its p99, with the count
    of its calls), the first attacker's reply. ``before(socket, uuid)``: each connection's
    preparation, made before the other client starts."""
    socks = [t.socket(ctx, timeout_ms=240_000) for _ in range(attackers)]
    for k, sock in enumerate(socks):
        if before is not None:
            before(sock, f"a{k}")
    stop, latencies, replies = threading.Event(), [], []

    def victim() -> None:
        sock = t.socket(ctx, timeout_ms=240_000)
        while not stop.is_set():
            start = time.perf_counter()
            try:
                call(sock, "sim.getSimulationTime", uuid="victim")
            except zmq.Again:
                latencies.append(math.inf)
                break
            latencies.append(time.perf_counter() - start)
            time.sleep(0.02)
        sock.close(0)

    def attacker(k: int) -> None:
        try:
            replies.append(attack(socks[k], f"a{k}"))
        except zmq.Again:
            replies.append("no reply in 240 s")

    v = threading.Thread(target=victim, daemon=True)
    v.start()
    time.sleep(0.5)
    threads = [threading.Thread(target=attacker, args=(k,), daemon=True) for k in range(attackers)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(600)
    stop.set()
    v.join(300)
    for sock in socks:
        sock.close(0)
    p99 = sorted(latencies)[int(0.99 * (len(latencies) - 1))]
    return f"{max(latencies):.2f} s (p99 {p99:.2f} s, {len(latencies)} calls)", replies[0] if replies else "-"


def once(prepare, request):
    """An attack of one call: ``request(prepare(socket, uuid))``, its reply in short."""
    def attack(sock: zmq.Socket, uuid: str) -> str:
        func, *args = request(prepare(sock, uuid))
        return _short(call(sock, func, *args, uuid=uuid))
    return attack
