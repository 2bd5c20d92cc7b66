"""The simulation loop, neutral to the APIs it serves: one thread owns the simulation, paces and
steps it, keeps the synchronous barrier, and serves the requests its front doors deliver
(``core``: :class:`~simx_server.loop.core.Loop`); the typed interface between the loop and a
front door (``front_door``: :class:`~simx_server.loop.front_door.FrontDoor`,
:class:`~simx_server.loop.front_door.LoopAccess`); the one registry of every door's clients,
with their expiry and edit share (``clients``); the budgets (``budgets``); the sending thread
replies leave on (``courier``); rate-limited logs (``logs``); a front door without sockets for
the loop's tests (``in_process``).

Layer: below the front doors (``legacy``: V-REP's remote API over Zenoh; ``zmq``: CoppeliaSim's
ZMQ remote API), above ``commands``; imports ``scene``, ``sim`` and ``base``, never a front door.
"""
