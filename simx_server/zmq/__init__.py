"""CoppeliaSim's ZMQ remote API (protocol version 2): programs written for CoppeliaSim 4.3+ with
the official ``coppeliasim-zmqremoteapi-client`` run unchanged against simx-server.

Another transport beside Zenoh, served by the same loop: ``codec`` (CBOR requests read under
bounds, replies), ``frontend`` (the socket thread: a ROUTER socket, refusals, hand-off to the
simulation thread), ``service`` (the simulation thread's side: clients, stepping mode, the calls),
``remote_sim`` (``sim`` over ZMQ: the child scripts' facade plus what remote programs need),
``pose_math`` (CoppeliaSim's pose arithmetic), ``names`` (what ``zmqRemoteApi.info`` lists, from
``coppeliasim_api.json``) and ``remote_api`` (the piece the command line attaches to the server).
docs/PROTOCOL.md, part 2, is the wire protocol; docs/ZMQ.md what simx implements.

Layer: above ``legacy`` (it attaches to its server and imports nothing else of it), below the
command line; imports ``commands``, ``scene``, ``scripts``, ``sim`` and ``base``. Its socket
thread never touches MuJoCo.
"""
