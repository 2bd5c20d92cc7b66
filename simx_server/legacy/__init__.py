"""The legacy remote API's front door: V-REP's ``simx*`` calls over Zenoh, attached to the
simulation loop (:mod:`simx_server.loop`). ``server`` (``LegacyDoor``: the Zenoh queryable,
requests and their budgets; ``Server``: a loop with this door attached), ``client_commands``
(synchronous mode, the last errors, forgetting a client), the clients' sessions and bounded
queues (``sessions``), which Zenoh session holds a client's token (``peers``), streamed
commands (``streams``), replies and their budget (``replies``), script consoles
(``consoles``), the viewer feed (``viewer_feed``), what the loop does for the scene's scripts
(``script_hooks``), the Zenoh configuration (``zenoh_config``) and malloc's settings
(``allocator``).

Layer: a front door above ``loop``, beside ``zmq`` (neither imports the other), below the
command line (``cli``, ``pool``); imports ``loop``, ``commands``, ``scene``, ``sim`` and
``base``. Zenoh callbacks here never touch MuJoCo.
"""
