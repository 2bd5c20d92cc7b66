"""The loop's one registry of clients, whatever front door they came through.

A front door registers each client it serves (:meth:`Clients.add`: a :class:`Client`, or a
subclass of it that carries what is the door's own: its Zenoh intake, its ZMQ stepping level),
notes each of its requests (``Client.last_seen``) and removes it when it leaves
(:meth:`Clients.remove`). The registry keeps what every door needs of a client:

* its identity (``id``, unique within its door) and its door;
* ``last_seen`` (``time.monotonic()``, s) and ``expiry`` (s of silence before it is dropped):
  the loop's housekeeping asks :meth:`Clients.expired` who is past it, and calls each one's
  door's ``forget`` (a door may keep a client past its expiry: :meth:`FrontDoor.keeps
  <simx_server.loop.front_door.FrontDoor.keeps>`, a liveliness token, a reply waiting for a step);
* its share of the simulation thread for scene loads and edits (``share``,
  :class:`~simx_server.loop.budgets.Share`);
* ``fault``: the message of a failed simulation step, told at its next request
  (:meth:`Clients.fault_all` marks every client of every door);
* the counts the loop's ``--speed 0`` idling looks at (:meth:`Clients.count`).

Simulation thread only: no lock (the doors' own threads keep their own intake state).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from simx_server.loop.budgets import Share


class Client:
    """One client of a front door.

    Args:
        client_id: the client's identity within its door (a legacy client id, a ZMQ uuid).
        door: the front door it came through.
        now: ``time.monotonic()`` (s) of its first request.
        expiry: s it may stay silent before the loop drops it.
    """

    __slots__ = ("door", "expiry", "fault", "id", "last_seen", "share")

    def __init__(self, client_id: str, door: Any, now: float, expiry: float) -> None:
        self.id = client_id
        self.door = door
        self.last_seen = now
        self.expiry = expiry
        self.share = Share(now)  # its share of the simulation thread (scene loads and edits)
        self.fault: str | None = None  # a failed step's message, told at its next request

    def expired_how(self) -> str:
        """What the log says when this client expires (a door's kind of client may say more)."""
        return f"expired (no request for {self.expiry:g} s)"


class Clients:
    """Every front door's clients, by door and id (see the module docstring)."""

    def __init__(self) -> None:
        self._doors: dict[int, tuple[Any, dict[str, Any]]] = {}  # id(door) -> (door, id -> client)

    def of(self, door: Any) -> dict[str, Any]:
        """The clients of ``door`` by id (the registry's own dict: read it, change it through
        :meth:`add` and :meth:`remove`)."""
        entry = self._doors.get(id(door))
        if entry is None:
            entry = self._doors[id(door)] = (door, {})
        return entry[1]

    def get(self, door: Any, client: str) -> Any:
        """The client ``client`` of ``door``, or None."""
        entry = self._doors.get(id(door))
        return entry[1].get(client) if entry is not None else None

    def add(self, client: Client) -> None:
        """Register ``client`` (replacing one of its door with the same id)."""
        self.of(client.door)[client.id] = client

    def remove(self, client: Client) -> bool:
        """Drop ``client``; False when it was not registered (dropped already)."""
        clients = self.of(client.door)
        if clients.get(client.id) is not client:
            return False
        del clients[client.id]
        return True

    def __iter__(self) -> Iterator[Any]:
        for _, clients in list(self._doors.values()):
            yield from list(clients.values())

    def count(self, door: Any = None) -> int:
        """Clients of ``door`` (of every door when None)."""
        if door is not None:
            entry = self._doors.get(id(door))
            return len(entry[1]) if entry is not None else 0
        return sum(len(clients) for _, clients in self._doors.values())

    def expired(self, now: float) -> list[Any]:
        """The clients silent for longer than their ``expiry`` at ``now``, oldest first, but
        those their door keeps (its ``keeps(client)``). They stay registered: the loop has
        their door forget them."""
        out: list[Any] = []
        for door, clients in list(self._doors.values()):
            out.extend(c for c in clients.values() if now - c.last_seen > c.expiry and not door.keeps(c))
        out.sort(key=lambda c: c.last_seen)
        return out

    def oldest(self, door: Any, where: Callable[[Any], bool]) -> Any:
        """The client of ``door`` silent the longest among those ``where`` accepts, or None
        (a door that must make room drops it)."""
        candidates = [c for c in self.of(door).values() if where(c)]
        return min(candidates, key=lambda c: c.last_seen) if candidates else None

    def fault_all(self, message: str) -> None:
        """Every client of every door is told ``message`` at its next request (a failed step)."""
        for client in self:
            client.fault = message
