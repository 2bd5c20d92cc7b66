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
MAX_COMMANDS_PER_REQUEST = 4096
#: Largest request payload in bytes (a simxTransferFile of a mesh or a scene included).
MAX_REQUEST_BYTES = 64 * 1024 * 1024
#: Largest reply a request may produce in bytes (images and buffers included).
MAX_REPLY_BYTES = 128 * 1024 * 1024

# ----------------------------------------------------------------- command identity (issue 11, client part)
#: Container levels of an identifying argument that ``protocol.identity`` keeps as nested tuples;
#: deeper levels are flattened into one tuple, built without recursion, so a request whose
#: arguments are nested 1,000 deep costs no deep recursion. Defined beside ``identity`` in
#: ``simx_client.protocol`` (the client package imports nothing of the server), named here.
from simx_client.protocol import IDENTITY_DEPTH  # noqa: E402,F401
#: Range of an integer argument accepted by the drop-in client (the C API's ``simxInt``); beyond
#: it a ``simx*`` call answers ``simx_return_local_error_flag`` (32) and sends nothing.
from simx_client.api import _INT_MAX, _INT_MIN  # noqa: E402

CLIENT_INT_RANGE = (_INT_MIN, _INT_MAX)
