"""Handshake slots kept free for new legacy clients: the oldest connections that are not a Zenoh
session yet are closed once there are too many of them.

Zenoh bounds handshakes under way by itself (``transport/unicast/accept_pending``, with
``accept_timeout`` for each; :mod:`simx_server.legacy.zenoh_config` sets both) and, once they are
all taken, closes the *newest* connection at once. One process holding 5,000 idle TCP connections
to the legacy port, each reopened as soon as it is closed, therefore kept every slot and locked
every new legacy client out (0 of 4 served in 30 s). Zenoh has no per-address bound (on loopback,
where clients and attacker share 127.0.0.1, one would not tell them apart anyway) and no way to
drop the oldest. :class:`HandshakeGuard` adds that: every ``limits.ZENOH_SWEEP_SECONDS`` it lists
the server's TCP connections on its legacy ports (``/proc/self/net/tcp``, ``tcp6``), asks the
session's own admin space which of them are Zenoh sessions (their links), and once more than
three quarters of ``accept_pending`` are not, closes the oldest of those down to half of it
(``shutdown`` of the socket, which ends Zenoh's handshake on it and frees its slot; one log
line), sweeping again a quarter interval later while it had to: a new connection then finds a
slot and finishes its handshake (a millisecond on loopback) long before it is the oldest. A
session is never closed; fewer idle connections than that are left to Zenoh's
``accept_timeout`` (closing them would only make their owner open them again). While the
process holds fewer descriptors than the trigger, a sweep only counts them.

The admin space is turned on for the server's session alone (``adminspace`` with ``read`` and
``write`` false: no peer can query it; :func:`simx_server.legacy.zenoh_config.zenoh_config`); an
operator's Zenoh file with an ``adminspace`` section of its own keeps it, and without the admin
space the guard does not run (one log line). Linux only (``/proc``); TCP and TLS listeners.
"""

from __future__ import annotations

import ipaddress
import json
import logging
import os
import socket
import stat
import threading
import time
from typing import Any

from simx_server.base import limits

log = logging.getLogger("simx.server")

_ESTABLISHED = "01"  # a connection's state in /proc/net/tcp
_TABLES = ("/proc/self/net/tcp", "/proc/self/net/tcp6")
Peer = tuple[Any, int]  # (ipaddress of the client, its port)


def _address(hex_ip: str) -> Any:
    """An address of /proc/net/tcp (little-endian 32-bit words), IPv4 where it is one mapped."""
    raw = bytes.fromhex(hex_ip)
    ip = ipaddress.ip_address(b"".join(raw[k:k + 4][::-1] for k in range(0, len(raw), 4)))
    mapped = getattr(ip, "ipv4_mapped", None)
    return mapped if mapped is not None else ip


def connections(ports: set[int]) -> dict[int, Peer]:
    """This process's established TCP connections whose local port is one of ``ports``: socket
    inode -> the peer's (address, port)."""
    found: dict[int, Peer] = {}
    for table in _TABLES:
        try:
            with open(table) as rows:
                next(rows, None)
                for row in rows:
                    cols = row.split()
                    if len(cols) < 10 or cols[3] != _ESTABLISHED or int(cols[1].rsplit(":", 1)[1], 16) not in ports:
                        continue
                    ip, port = cols[2].rsplit(":", 1)
                    found[int(cols[9])] = (_address(ip), int(port, 16))
        except OSError:  # no IPv6, or no /proc
            continue
    return found


def _peer(locator: str) -> Peer | None:
    """(address, port) of a Zenoh locator ``tcp/127.0.0.1:4711`` (``tls/[::1]:4711#iface=lo``)."""
    address = locator.split("/", 1)[-1].split("#", 1)[0].split("?", 1)[0]
    host, _, port = address.rpartition(":")
    try:
        ip = ipaddress.ip_address(host.strip("[]"))
        mapped = getattr(ip, "ipv4_mapped", None)
        return (mapped if mapped is not None else ip), int(port)
    except ValueError:
        return None


def listen_ports(config: Any) -> set[int]:
    """The TCP ports of a Zenoh config's ``tcp/`` and ``tls/`` listen endpoints (0 left out)."""
    listen = json.loads(config.get_json("listen/endpoints") or "[]")
    flat = [e for v in listen.values() for e in v] if isinstance(listen, dict) else listen
    peers = [_peer(e) for e in flat if isinstance(e, str) and e.startswith(("tcp/", "tls/"))]
    return {p[1] for p in peers if p is not None and p[1]}


class HandshakeGuard:
    """Closes the oldest connections to ``ports`` that are not a session of ``session`` once
    there are more than ``high`` of them, down to ``low`` (see the module docstring).

    Args:
        session: the server's Zenoh session (its admin space on).
        ports: the legacy door's TCP ports.
        slots: Zenoh's handshake slots (``accept_pending``): ``high`` is three quarters of them,
            ``low`` half.
        interval: s between sweeps (a quarter of it after a sweep that closed some).
    """

    def __init__(self, session: Any, ports: set[int], slots: int, interval: float = limits.ZENOH_SWEEP_SECONDS):
        self.session, self.ports, self.interval = session, ports, interval
        self.high, self.low = slots * 3 // 4, slots // 2
        self._seen: dict[int, float] = {}  # inode -> when a sweep first saw it
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.closed = 0  # connections closed so far
        self._logged = 0.0

    @classmethod
    def of(cls, session: Any, config: Any) -> HandshakeGuard | None:
        """The guard of the server's session opened with ``config``, or None when it cannot run
        (no admin space, no TCP or TLS port)."""
        ports = listen_ports(config)
        if not json.loads(config.get_json("adminspace/enabled") or "false") or not ports:
            log.info("new legacy clients' handshake slots are Zenoh's alone (accept_pending): the Zenoh config "
                     "turns its admin space off or listens on no TCP/TLS port (docs/SECURITY.md)")
            return None
        return cls(session, ports, int(json.loads(config.get_json("transport/unicast/accept_pending") or "100")))

    def start(self) -> None:
        """Sweep on a thread of its own until :meth:`close`."""
        self._thread = threading.Thread(target=self._run, name="simx-handshakes", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop sweeping (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)
            self._thread = None

    def _run(self) -> None:
        wait = self.interval
        while not self._stop.wait(wait):
            try:
                wait = self.interval / 4 if self.sweep() else self.interval
            except Exception:  # the door goes on without the guard's sweep this time
                log.exception("sweeping the legacy port's handshakes")

    def sweep(self) -> int:
        """One sweep: past :attr:`high` connections that are not a session, close the oldest of
        them down to :attr:`low`.

        Returns:
            How many it closed.
        """
        try:
            if len(os.listdir("/proc/self/fd")) <= self.high:  # nothing can be over the bound
                self._seen.clear()
                return 0
        except OSError:
            return 0
        now = time.monotonic()
        found = connections(self.ports)
        self._seen = {inode: self._seen.get(inode, now) for inode in found}
        if len(found) <= self.high:
            return 0
        sessions = self._sessions()
        waiting = sorted((self._seen[inode], inode) for inode, peer in found.items() if peer not in sessions)
        if len(waiting) <= self.high:
            return 0
        excess = len(waiting) - self.low
        closed = self._close({inode for _, inode in waiting[:excess]})
        self.closed += closed
        if closed and now - self._logged >= 10.0:  # one line per 10 s at most
            self._logged = now
            log.warning("closed %d connection(s) to the legacy port that were not a Zenoh session yet, the oldest "
                        "of %d (more than %d of Zenoh's handshake slots: some stay free for new clients; %d in all)",
                        closed, len(waiting), self.high, self.closed)
        return closed

    def _sessions(self) -> set[Peer]:
        """The peers of the session's Zenoh links (its admin space)."""
        zid = str(self.session.info.zid())
        peers: set[Peer] = set()
        for reply in self.session.get(f"@/{zid}/session/transport/unicast/*/link/*", timeout=2.0):
            try:
                peer = _peer(json.loads(reply.ok.payload.to_string()).get("dst", ""))
            except (AttributeError, TypeError, ValueError):  # an error reply, or not a link's
                continue
            if peer is not None:
                peers.add(peer)
        return peers

    @staticmethod
    def _close(inodes: set[int]) -> int:
        """``shutdown`` the sockets of ``inodes`` among this process's descriptors; how many."""
        closed = 0
        for name in os.listdir("/proc/self/fd"):
            try:
                fd = int(name)
                status = os.fstat(fd)
                if not stat.S_ISSOCK(status.st_mode) or status.st_ino not in inodes:
                    continue
                own = os.dup(fd)  # checked again on the copy: the number may have been reused meanwhile
            except (OSError, ValueError):
                continue
            sock = socket.socket(fileno=own)
            try:
                if os.fstat(own).st_ino in inodes:
                    sock.shutdown(socket.SHUT_RDWR)  # Zenoh's read ends: it drops the handshake
                    closed += 1
            except OSError:
                pass
            finally:
                sock.close()
        return closed
