"""Every bound the server puts on what a client can make it do, in one place.

Clients are untrusted (docs/SECURITY.md): each value that sets work per request, per step or
per scene has a bound here, named in the ``ArgumentError`` (or refusal) a client gets when it
asks for more. The values are chosen so that real legacy programs never meet them; where a
bound has a command-line flag, the flag is named beside it. docs/SECURITY.md lists them all.
"""

from __future__ import annotations

# ----------------------------------------------------------------- simulation step
#: Largest simulation step ``dt`` in s (``--dt``, ``sim_floatparam_simulation_time_step``).
MAX_DT = 1.0
#: Most MuJoCo substeps in one simulation step (``dt`` / the model's timestep).
MAX_SUBSTEPS = 10_000

# ----------------------------------------------------------------- vision sensors
#: Largest side of a vision sensor's image in pixels (resolution parameters 1002/1003).
MAX_RESOLUTION = 4096

# ----------------------------------------------------------------- requests
#: Most commands in one request (a simxPauseCommunication batch of a real program holds tens).
MAX_COMMANDS_PER_REQUEST = 1024
#: Largest request payload in bytes (a simxTransferFile of a mesh or a scene included).
MAX_REQUEST_BYTES = 64 * 1024 * 1024
#: Largest reply a request (or a stream update) may produce in bytes, images and buffers
#: included: one image of the largest resolution (MAX_RESOLUTION², depth as float32: 64 MiB)
#: fits. Commands past the budget get an error result naming this bound.
MAX_REPLY_BYTES = 80 * 1024 * 1024

# ================================================================ requests and clients
# (the server core: intake, fairness, reply size, client expiry, log repetition; server.py,
# sessions.py, logs.py). docs/SECURITY.md, "Requests and clients", explains each one.

# The request bounds (MAX_COMMANDS_PER_REQUEST, MAX_REQUEST_BYTES, MAX_REPLY_BYTES) are in
# "requests" above; this section adds the bounds on queues, clients and the log.

#: Requests of one client waiting for the simulation thread; a request beyond is answered at
#: once with an error result per command (remote error 8 at the facade), never queued.
MAX_QUEUED_REQUESTS = 256
#: Bytes (request payloads) one client may have waiting; a single largest request still fits.
MAX_QUEUED_BYTES = MAX_REQUEST_BYTES + 1024 * 1024
#: Bytes (request payloads) all clients together may have waiting.
MAX_QUEUED_BYTES_TOTAL = 256 * 1024 * 1024
#: Clients the server keeps state for (queue, streams, errors). A new client beyond takes the
#: place of the oldest client that holds no liveliness token and has nothing pending, or is refused.
MAX_CLIENTS = 1024
#: Replies (and stream updates) of one client waiting for the render thread. A client at the
#: bound is not served until one is sent; its image streams skip steps meanwhile.
MAX_RENDERS_PER_CLIENT = 4
#: Streamed commands of one client (each is executed again after every step).
MAX_STREAMS_PER_CLIENT = 256
#: Characters of an error message kept (reply, simxGetLastErrors); longer ones are cut.
MAX_ERROR_CHARS = 1000
#: Auxiliary consoles open at once (simxAuxiliaryConsoleOpen; shared by every client).
MAX_CONSOLES = 64
#: Lines of one simxAuxiliaryConsolePrint written to the log (the rest are counted).
MAX_CONSOLE_LINES = 100
#: Error messages kept per client for simxGetLastErrors (the oldest are dropped).
MAX_ERRORS_KEPT = 50

#: s a client without a liveliness token may stay silent before its state (streams, errors,
#: queue, synchronous ownership) is dropped (``--client-expiry``). A client holding its token
#: is never expired.
CLIENT_EXPIRY = 30.0

#: Identical log lines (same logger, level and text) let through per interval...
LOG_REPEAT_BURST = 5
#: ...and lines of one kind (same logger, level and message template, whatever the client's
#: values in it), so that varying the input does not get past the limit...
LOG_TEMPLATE_BURST = 100
#: ...per interval in s, at the end of which one summary line gives the count of those held
#: back and the last of them (``--log-interval``).
LOG_REPEAT_INTERVAL = 10.0
#: Windows (texts and templates) tracked at once (the least recently seen are forgotten).
LOG_REPEAT_KEYS = 1024
