"""Zenoh on the outside, one simulation thread on the inside: the server loop (``server``), the
clients' sessions and bounded queues (``sessions``), streamed commands (``streams``), replies and
their budget (``replies``), script consoles (``consoles``), rate-limited logs (``logs``), the
viewer feed (``viewer_feed``) and the Zenoh configuration (``zenoh_config``).

Layer: below the command line (``cli``, ``pool``); imports ``commands``, ``scene``, ``sim`` and
``base``. Zenoh callbacks here never touch MuJoCo.
"""
