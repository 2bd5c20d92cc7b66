"""CoppeliaSim's ZMQ remote API (protocol version 2): programs written for CoppeliaSim 4.3+ with
the official ``coppeliasim-zmqremoteapi-client`` run unchanged against simx-server.

The ZMQ front door of the simulation loop (``simx_server.loop``), beside the legacy one over
Zenoh: ``codec`` (CBOR requests read under bounds, replies), ``frontend`` (the socket thread: a
ROUTER socket, refusals, hand-off to the simulation thread), ``service`` (the simulation
thread's side: clients, stepping mode, the calls), ``renders`` (the calls whose replies leave
from the render thread), ``budgets``, ``clients``, ``gate`` (who may connect), ``coverage`` (what
simx implements of ``coppeliasim_api.json``) and ``remote_api`` (the front door the command line
attaches to the loop). The calls themselves are the API table of :mod:`simx_server.api`, the same
functions child scripts call (``sim`` over ZMQ: :func:`simx_server.api.client_context`;
what ``zmqRemoteApi.info`` lists: :mod:`simx_server.api.names`). docs/PROTOCOL.md, part 2, is the wire
protocol; docs/ZMQ.md what simx implements.

Layer: a front door above ``loop`` (it sees the loop through ``loop.front_door``'s interface),
beside ``legacy`` (which it does not import), below the command line; imports ``api``,
``commands``, ``loop``, ``sim`` and ``base``. Its socket thread never touches MuJoCo.
"""
