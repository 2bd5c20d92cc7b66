"""Every bound the server puts on what a client can make it do, in one place.

Clients are untrusted (docs/SECURITY.md): each value that sets work per request, per step or
per scene has a bound here, named in the ``ArgumentError`` (or refusal) a client gets when it
asks for more. The values are chosen so that real legacy programs never meet them; where a
bound has a command-line flag, the flag is named beside it. docs/SECURITY.md lists them all.
"""

from __future__ import annotations

from simx_wire import protocol as P

# ----------------------------------------------------------------- simulation step
#: Largest simulation step ``dt`` in s (``--dt``, ``sim_floatparam_simulation_time_step``); dt
#: must also be > 0 and finite. V-REP's default is 0.05 s; 1 s of the UR5 scene is 1,000
#: MuJoCo substeps, about 10 ms of CPU.
MAX_DT = 1.0
#: Most MuJoCo substeps in one simulation step (``dt`` / the model's timestep): the work of one
#: step. Checked when dt changes and when a scene loads (a scene whose ``<option timestep>`` is
#: too small for the dt is refused).
MAX_SUBSTEPS = 10_000

# ----------------------------------------------------------------- vision sensors
#: Largest side of a vision sensor's image in pixels (resolution parameters 1002/1003; the MJCF
#: camera's ``resolution``, checked when a scene loads). A 4096x4096 RGB image is 48 MiB and its
#: depth buffer 64 MiB, both under MAX_REPLY_BYTES.
MAX_RESOLUTION = 4096
#: Most renderers (an MjrContext and offscreen buffer each, one per image size) a render thread keeps;
#: resolutions set at run time beyond that close the least recently used.
MAX_RENDERERS = 8

# ----------------------------------------------------------------- requests
#: Most commands in one request (a simxPauseCommunication batch of a real program holds tens);
#: the protocol's value, which the client's outbox splits its batches by.
MAX_COMMANDS_PER_REQUEST = P.MAX_COMMANDS_PER_REQUEST
#: Largest request payload in bytes (a simxTransferFile of a mesh or a scene included).
MAX_REQUEST_BYTES = P.MAX_REQUEST_BYTES
#: Largest Zenoh message the server's session reassembles (Zenoh's
#: ``transport/link/rx/max_message_size``, 1 GiB by default): a request and its framing. Zenoh
#: reassembled a 900 MiB query before the server could refuse it (106 -> 1,910 MB, 1,010 MB kept).
MAX_ZENOH_MESSAGE_BYTES = MAX_REQUEST_BYTES + 2 * 1024 * 1024
#: Most values (at any depth) and most memory once decoded of one request, measured on its bytes
#: before it is decoded (simx_wire.decoded_size): a byte of msgpack can become 60-90 bytes of
#: Python objects (62.9 M empty arrays in 60 MiB took a server to 4.7 GB).
MAX_REQUEST_ITEMS = P.MAX_REQUEST_ITEMS
MAX_REQUEST_DECODED_BYTES = P.MAX_REQUEST_DECODED_BYTES
#: Largest reply a request may produce in bytes (images and buffers included).
MAX_REPLY_BYTES = 128 * 1024 * 1024

# ----------------------------------------------------------------- physics
# Ranges of the values clients (and child scripts) write into MuJoCo's model and data. Each is
# far beyond what a real robot program sets, and small enough that MuJoCo's arithmetic stays
# finite (products of two bounded values stay far below 1e308). Values outside (NaN and
# infinities included) are refused with an ArgumentError naming the bound (docs/SECURITY.md).

#: Largest magnitude of gravity in m/s² (``sim_arrayparam_gravity``): 100 g.
MAX_GRAVITY = 1000.0
#: Smallest and largest mass of a shape in kg (``sim_shapefloatparam_mass``, 3005): 1 mg, 1000 t.
MIN_MASS = 1e-6
MAX_MASS = 1e6
#: Largest principal inertia in kg·m² (inertias scale with a new mass, as in V-REP).
MAX_INERTIA = 1e8
#: Largest coordinate of an object's position in m (``simxSetObjectPosition``: |x|, |y|, |z|).
MAX_POSITION = 1e4
#: Largest joint position or target position (rad or m) a client sets.
MAX_JOINT_POSITION = 1e4
#: Largest target velocity and velocity limit of a joint (rad/s or m/s); torque control through
#: a large target velocity (the usual 1e4 or 9999) stays within it.
MAX_JOINT_VELOCITY = 1e6
#: Largest maximum force/torque of a joint motor (N or N·m, ``simxSetJointForce``).
MAX_JOINT_FORCE = 1e8

# ----------------------------------------------------------------- signals
#: Most signals in the server's store (integer, float and string signals together).
MAX_SIGNALS = 10_000
#: Largest string signal in bytes (``simxSetStringSignal``, ``simxAppendStringSignal``,
#: ``simxWriteStringStream``): room for a packed 1920x1080 RGB image and more.
MAX_SIGNAL_BYTES = 16 * 1024 * 1024
#: Largest size of the whole store in bytes (names and values; a number counts 8 bytes).
MAX_SIGNAL_STORE_BYTES = 64 * 1024 * 1024
#: Longest signal name in characters.
MAX_SIGNAL_NAME = 1024
#: Script simulation parameters and user parameters (``sim.setScriptSimulationParameter``,
#: ``sim.setUserParameter``) of all the scene's scripts and objects, bounded as signals: most
#: entries, largest value in bytes, largest total (names and values). The total also counts
#: toward MAX_SCRIPTS_MEMORY, beside the Lua states.
MAX_PARAMETERS = MAX_SIGNALS
MAX_PARAMETER_BYTES = MAX_SIGNAL_BYTES
MAX_PARAMETER_STORE_BYTES = MAX_SIGNAL_STORE_BYTES

# ----------------------------------------------------------------- scenes and files
# Files sent with simxTransferFile, and what a scene or model sent by a client may hold. A
# client-sent MJCF file is measured before MuJoCo parses it (its XML, with <include>s and
# <replicate> counts multiplied out) and its MjSpec again before it is compiled, so that a
# refused scene costs milliseconds: MuJoCo's parse and compile run on the simulation thread
# and cannot be interrupted, so every other client waits while a scene loads. Measured on the
# loaded 2-core development machine, LoadScene of a client's scene at one bound takes: 1,000
# bodies 0.13-0.18 s, a 4096x4096 texture 0.14-0.25 s, a 200,000-vertex mesh 0.34-1.2 s; with
# every bound reached at once, about 3 s at worst. Above the bounds time grows fast (MuJoCo's
# parse is quadratic: 10,000 replicated bodies took 10.7 s, 90,000 froze clients 22.6 s).
# Files of the operator (the scene on the command line, --scene-path folders) are not
# measured; edits by clients are (bodies and elements).
# Files clients write (issue 40): each client writes only into its own folder of the transfer
# folder (simxTransferFile, sim.saveScene, sim.saveImage, sim.exportMesh...), within its own
# budget, so one client's files never use up another's room (8 x 32 MiB from one client once
# locked every other out until a restart); the total bounds the disk all of them take.
#: Largest file one simxTransferFile may store, in bytes.
MAX_TRANSFER_FILE_BYTES = 32 * 1024 * 1024
#: Most bytes one client's folder may hold (its transfers and the files its calls wrote).
MAX_CLIENT_FILES_BYTES = 64 * 1024 * 1024
#: Most bytes all clients' folders together may hold.
MAX_TRANSFER_FOLDER_BYTES = 1024 * 1024 * 1024
#: Shares of that total (issue 48: 16 clients x 64 MiB filled it in 9 s and every other client's
#: 1 kB file was refused for as long as they stayed): each client may always hold this many bytes
#: ("its minimum": RESERVED_CLIENT_FILES_BYTES, after MAX_CLIENTS below, keeps room for the
#: minimum of every client the server can hold at once), and above it draws on the rest of the
#: total (MAX_TRANSFER_FOLDER_BYTES - RESERVED: the pool), at most the pool divided by the number
#: of clients holding files: a share that shrinks as clients come (files already written stay;
#: its next write waits until it erases some). A minimum of 1 MiB with room for 256 of them let a
#: group of 268 clients (12 at 64 MiB, the others at their minimum) fill the total: a newcomer's
#: 1 kB file was refused.
MIN_CLIENT_FILES_BYTES = 128 * 1024
#: Bytes of simxTransferFile taken from the requests and not written yet (the files' thread
#: writes them), of one client and of all: beyond, "server busy" (the client sends it again); a
#: client with none may always hand over one file of at most MIN_CLIENT_FILES_BYTES (at most
#: MAX_FILE_HOLDERS x 128 KiB more in all).
MAX_UNWRITTEN_BYTES = 64 * 1024 * 1024
MAX_UNWRITTEN_BYTES_TOTAL = 256 * 1024 * 1024
#: Most files and folders one client's folder may hold.
MAX_TRANSFER_FILES = 1000
#: Longest file name a client may give, in UTF-8 bytes, and longest part of it between two ``/``
#: (the file system's 255, less the ``.part`` a file is written under first): a 5,000-character
#: name made simxEraseFile raise ENAMETOOLONG, whose message named the server's folder.
MAX_FILE_NAME_BYTES = 1024
MAX_FILE_NAME_PART_BYTES = 250
#: Most bytes of MJCF a client may have loaded at once (a scene or model with its <include>s).
MAX_SCENE_FILE_BYTES = 4 * 1024 * 1024
#: Largest asset file (mesh, texture, height field, skin) a client-sent scene may name, in bytes.
MAX_ASSET_FILE_BYTES = 16 * 1024 * 1024
#: Deepest nesting of XML elements and <include>s in a client-sent file.
MAX_XML_DEPTH = 100
#: Most bodies (and flexes) in a client-sent scene, and in a scene after a client's edit.
MAX_SCENE_BODIES = 1000
#: Most elements of every kind (geoms, joints, sites, actuators, ...) likewise.
MAX_SCENE_ELEMENTS = 10_000
#: Most pixels of one texture (all six faces of a cube), and of all textures of a scene.
MAX_TEXTURE_PIXELS = 4096 * 4096
MAX_SCENE_TEXTURE_PIXELS = 2 * MAX_TEXTURE_PIXELS
#: Most cells of one height field (nrow x ncol), and of all height fields of a scene.
MAX_HFIELD_CELLS = 2048 * 2048
MAX_SCENE_HFIELD_CELLS = 2 * MAX_HFIELD_CELLS
#: Most vertices of one mesh (counted in the file or the vertex list) or flex, and of all of
#: them in a scene (MuJoCo computes each mesh's convex hull: 200,000 vertices take 0.3-1 s).
MAX_MESH_VERTICES = 200_000
MAX_SCENE_MESH_VERTICES = 2 * MAX_MESH_VERTICES
#: Most faces (triangles, a polygon counting as its fan) of one mesh, and of all meshes of a
#: scene (a client's, and any scene a client's edit adds meshes to): the compile's time and memory
#: grow with faces (a 199,000-vertex, 396,000-face OBJ: 0.8 s of CPU, +396 MB at the compile's
#: peak, 272 MB of it kept in MuJoCo's mesh cache); two in-bounds 199,000-vertex meshes of 470,000
#: faces each froze every client 9.4 s and took a server from 230 MB to 1,349 MB, and two of
#: 396,000 faces, within the 800,000 then allowed a scene, still took it to 1,288 MB at its peak.
MAX_MESH_FACES = 400_000
MAX_SCENE_MESH_FACES = MAX_MESH_FACES
#: Most bytes of MuJoCo's data arena (contacts, constraints and the solver's scratch memory)
#: of a client's scene or of a scene after a client's edit: its <size memory>, and the compiled
#: model's ``narena``, which MuJoCo sizes itself when the MJCF does not (100 free spheres: 57
#: MiB, 300: 227 MiB, 1,000: 1.65 GiB), checked before the scene's MjData exists. It also bounds
#: the constraints one substep can solve: with 64 MiB, 160 overlapping spheres (44,000
#: constraint rows) take 7.9 s in one substep of MuJoCo's Newton solver, the most seen.
MAX_ARENA_BYTES = 64 * 1024 * 1024
#: Most contacts of a client's scene as loaded (collision detection alone on scratch data, no
#: solver: about 10 ms for 300 overlapping spheres), so that overlapping bodies are refused
#: before their first step: 300 overlapping spheres make 24,911 contacts, whose first substep
#: takes 30 s; a pile of 300 settled spheres 950.
MAX_SCENE_CONTACTS = 2000
#: s of the simulation thread one step of a client's scene may take: its substeps run one at a
#: time, and past this the simulation stops (as after a blow-up, every client is told, naming
#: this bound). 300 spheres falling into a pile reach 1.5 s per step with MuJoCo's defaults.
MAX_STEP_SECONDS = 1.0
#: Most work of one simulation step of a client's scene or edit, estimated as MuJoCo substeps x
#: solver iterations x geoms (the bundled UR5 scene: about 1.9e5): checked after compiling,
#: before the scene replaces the current one (300 piled spheres, 1,000 iterations and a 5e-4 s
#: timestep, 3e7, froze every client for over 90 s).
MAX_STEP_WORK = 5_000_000
#: Most entries of the other <size> fields (nuserdata, nkey, nuser_*, njmax, nconmax, nstack),
#: and values of one <numeric>.
MAX_SIZE_ENTRIES = 100_000
#: Most solver iterations per step (<option iterations, ls_iterations, noslip_iterations,
#: ccd_iterations, sdf_iterations>): MuJoCo's defaults are 100, 50, 0, 35, 10.
MAX_SOLVER_ITERATIONS = 1000
#: Largest offscreen buffer and shadow map side (<visual><global offwidth/offheight>,
#: <quality shadowsize>), and most samples and slices (<quality offsamples, numslices, ...>).
MAX_VISUAL_SIZE = 4096
MAX_VISUAL_DETAIL = 64

# Client-side bounds live with the client (it imports nothing of the server):
# ``simx_wire.protocol.IDENTITY_DEPTH`` (container levels of an identifying argument kept as
# nested tuples; deeper levels are flattened without recursion) and the int32 range of
# ``simx_client.api`` (an integer beyond it is a local error, 32, and nothing is sent).

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
#: once with an error result per command (remote error 8 at the facade), never queued. Room for
#: a real program's burst of oneshot calls on a loaded machine (hundreds of setters sent at
#: once); the per-client and total byte bounds below still bound the memory.
MAX_QUEUED_REQUESTS = 1024
#: Bytes one client may have waiting, counted as decoded requests take them (read_request's
#: estimate, an upper bound); a single largest request still fits.
MAX_QUEUED_BYTES = MAX_REQUEST_DECODED_BYTES + 1024 * 1024
#: Bytes (decoded requests, likewise) all clients together may have waiting.
MAX_QUEUED_BYTES_TOTAL = 256 * 1024 * 1024
#: Requests of this many bytes or more are read (copied out of Zenoh, decoded, proven) on a thread
#: of their own, round robin by client, not on Zenoh's few receiving threads (simx_server/legacy/
#: intake.py): sixteen clients' 32 MiB files kept them busy 10 s, another client's p99 1.1-1.5 s.
LARGE_REQUEST_BYTES = 1024 * 1024
#: Payload bytes of one client's requests waiting for that thread (one largest request and small
#: ones behind it; more is answered "server busy"), and of all clients (beyond, a large request of a
#: client with none waiting is read on Zenoh's thread, which leaves the rest waiting in the network).
MAX_INTAKE_BYTES = MAX_REQUEST_BYTES + 1024 * 1024
MAX_INTAKE_BYTES_TOTAL = 256 * 1024 * 1024
#: Clients the server keeps state for (queue, streams, errors). A new client beyond takes the
#: place of the oldest client that holds no liveliness token and has nothing pending, or is refused.
MAX_CLIENTS = 1024
#: Clients that may hold files in the transfer folder at once: the legacy door's and the ZMQ
#: door's (MAX_CLIENTS each), the in-process caller, and a client gone whose folder holds the
#: loaded scene; and the room kept for each one's MIN_CLIENT_FILES_BYTES (256.25 MiB).
MAX_FILE_HOLDERS = 2 * MAX_CLIENTS + 2
RESERVED_CLIENT_FILES_BYTES = MAX_FILE_HOLDERS * MIN_CLIENT_FILES_BYTES
#: Simulation-thread time one request may take (s; the thread's CPU time): commands after that
#: point answer an error naming this bound, not executed (else a request of 100 LoadScene
#: commands would hold every client for over a minute). CPU time, because on a loaded machine
#: the thread is descheduled, not busy.
MAX_REQUEST_SECONDS = 0.5
#: Wall time one request may take (s), waits included (renders a script waits for): the same.
MAX_REQUEST_WALL_SECONDS = 2.0
#: Simulation-thread time (CPU, s) every client's streamed commands together may take after one
#: step: the streams not run by then skip that step, the clients taken in turn step by step.
MAX_STREAMS_STEP_SECONDS = 0.5
#: Share of the simulation thread a client's scene loads and edits (commands.NOT_STREAMABLE)
#: may take on average: each costs its own duration, the debt falls by this many s per s, and
#: while a client's debt exceeds EDIT_DEBT_SECONDS its loads and edits answer "busy".
EDIT_SHARE = 0.25
EDIT_DEBT_SECONDS = 5.0
#: Most clients (client ids) of one authenticated user at a time: ids are <user>-<uuid>, which
#: access control enforces (docs/SECURITY.md), so one user cannot take every client slot.
#: Anonymous ids (no user) share MAX_CLIENTS, at most MAX_CLIENTS_PER_PEER protected per session.
MAX_CLIENTS_PER_USER = 64
#: Client ids whose liveliness tokens one Zenoh session may hold with effect (legacy/peers.py):
#: the server queries each new token's ``protocol.peer_key`` and the reply names the session
#: that answers for the id. A token beyond this bound, or one nobody answers for, does not keep
#: its client: such clients expire when silent and are evicted first when the server is full.
#: A simx connection holds one id (its own session); one session declaring 1,100 tokens and
#: sending a request under each filled MAX_CLIENTS ("server busy" for everyone else).
MAX_CLIENTS_PER_PEER = 8
#: s the server waits for a session to answer its peer check; unanswered, the token does not protect.
PEER_CHECK_SECONDS = 2.0
#: Peer checks in flight at once; a token seen beyond does not protect its client.
MAX_PEER_CHECKS = 256
#: Liveliness tokens the server records (protecting or not); beyond, new tokens are ignored.
MAX_CLIENT_TOKENS = 2 * MAX_CLIENTS
#: Replies and stream updates of one client handed to the sending thread and not sent yet
#: (waiting for their images, or for room on the client's link). A client at the bound is not
#: served until one is sent; its streams skip steps meanwhile (a synchronous client's do not:
#: legacy/streams.py).
MAX_UNSENT_PER_CLIENT = 4
#: s a reply may wait for room on its client's link before Zenoh closes that link (Zenoh's
#: ``transport/link/tx/queue/congestion_control/block/wait_before_close``, default 5 s). A
#: client that stops reading (its socket full of the images it asked for) holds the sending
#: thread (loop.courier; not the simulation thread) that long, once: then its link is
#: closed and its replies are dropped. 0.5 s closed the link of a client reading large image
#: replies on a loaded 2-core machine (the fuzz test, once): 2 s. An operator's Zenoh config
#: file that sets the key keeps its own value.
MAX_BLOCKED_REPLY_SECONDS = 2.0
#: s the server waits for Zenoh's session to close when it stops: with a client that stopped
#: reading it took 11.6 s (Zenoh waits for every link); SIGTERM ends the server within 2 s.
ZENOH_CLOSE_SECONDS = 0.5
#: Steps whose streamed images the stream render thread may still be making, all clients
#: together: beyond, every client's image streams skip steps until it catches up (a stream gives
#: the newest frame, as V-REP's did). Two keep that thread busy when a frame takes about a step;
#: more let streams of huge images (tens of streams of a 4096x4096 sensor) queue seconds of
#: frames and memory; requests render on their own thread.
MAX_STREAM_STEPS_RENDERING = 2
#: Streamed frames of at least this many pixels render on the stream render thread (made on the
#: first such frame), so that they never delay another client's image request (1.5 s a frame at
#: 4096x4096 on llvmpipe); smaller ones (a Kinect's 640x480: about 20 ms) stay on the request
#: thread, and a server whose clients stream only those makes no second set of GL contexts.
STREAM_THREAD_PIXELS = 1024 * 1024
#: The stream render thread draws a frame in horizontal bands of at most this many pixels (a
#: 4096x4096 frame: 16 bands of 256 rows), each its own render: on software GL (Mesa's llvmpipe)
#: every GL context of the process shares one rasteriser queue, so another client's frame waits
#: behind one band instead of a whole 4096x4096 scene (400-800 ms). Bands cost more in all (the
#: shadow map and the scene are drawn once per band: 534 -> 1,129 ms for a 4096x4096 RGB image;
#: another client's p99 beside ten such streams 166-247 -> 59-60 ms, benchmarks/README.md part g).
STREAM_BAND_PIXELS = 1024 * 1024
#: The stream render thread draws at most this share of the time (STREAM_RENDER_DEBT_SECONDS
#: ahead): past it, image streams of large frames skip steps, leaving the CPU to requests.
STREAM_RENDER_SHARE = 0.5
STREAM_RENDER_DEBT_SECONDS = 0.5
#: A stream update or reply whose images take at least this many bytes is a *bulk* send: it is
#: put with Zenoh's blocking congestion control (with "drop", the fragments of a 50 MB update of a
#: 4096x4096 image were dropped every time: a streaming client received none in 10 s), and on the
#: sending thread it gives way to other clients' sends, for at most MAX_BULK_DEFER_SECONDS.
BULK_SEND_BYTES = 4 * 1024 * 1024
#: A reply of at most this many bytes, to a request served in place on Zenoh's thread
#: (loop.core.Loop.serve_or_deliver) by a client with no streams and nothing on its way, is sent
#: by that thread itself rather than the sending thread: one thread hand-over less per call.
#: Only such a client's own link can be full then (of its earlier replies it has not read).
IN_PLACE_REPLY_BYTES = 16 * 1024
MAX_BULK_DEFER_SECONDS = 0.5
#: Bulk stream updates take at most this share of the sending thread's time, with a debt of
#: BULK_DEBT_SECONDS allowed; past it an update is not pushed (its stream skips that step).
BULK_SHARE = 0.25
BULK_DEBT_SECONDS = 0.25
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


# ------------------------------------------------- names shared across MJCF kinds
#: Renamed elements (``NAME#N``, see simx_server.sim.naming) listed by name in the one WARNING line a
#: scene load writes about them; the rest are counted (each is named at DEBUG level). A few are
#: enough to show the rule: dm_control's quadruped renames 13.
MAX_RENAMES_LOGGED = 3

# ----------------------------------------------------------------- script calls
#: Most values (ints + floats + strings) one simxCallScriptFunction may pass to a child script:
#: checked before anything is converted, so that a Lua script's state (MAX_SCRIPT_MEMORY) can
#: always hold them (a real program passes a few thousand at most).
MAX_SCRIPT_CALL_VALUES = 1 << 20
#: Most bytes of strings and buffer one simxCallScriptFunction may pass to a child script.
MAX_SCRIPT_CALL_BYTES = 16 << 20
#: Memory cap of one Lua child script's state (bytes).
MAX_SCRIPT_MEMORY = 256 << 20
#: Most work of one Lua pattern match (string.find/match/gmatch/gsub, about 1 ns a step): the
#: matcher's worst case, estimated from the pattern before it runs (simx_server/scripts/lua_bounds.py:
#: ``?`` doubles the rest, ``*`` ``+`` ``-`` multiply it by n + 1, n + 1 starting points unless
#: anchored). The matcher is C code, which the scripts' instruction-count time bound does not reach.
MAX_PATTERN_WORK = 10 ** 8
#: CPU seconds all of a scene's scripts may take together in one pass of the simulation thread
#: (a simulation start; a step's actuation and sensing; an idle pass of customization scripts);
#: the script running when it ends is interrupted and named (simx_server/scripts/budget.py).
MAX_SCRIPTS_STEP_TIME = 2.0
#: CPU seconds of the scripts in each pass that are never charged to their share: a pass this
#: short keeps a client's call waiting no longer than a slow step would (V-REP's default step is
#: 50 ms; scripts of real scenes take a few ms a pass).
SCRIPTS_PASS_ALLOWANCE = 0.1
#: The fraction of the server's CPU time (SCRIPTS_SHARE_WINDOW) the scripts may take beyond their
#: per-pass allowances: at least the other half is left to the clients and the physics. Once it is
#: taken, each pass gets the allowance only, and the script running past it is interrupted, named
#: and its callbacks skipped until the next start (simx_server/scripts/budget.py). Every callback
#: counts: life-cycle functions, thread resumes, dynamics-step, joint and contact callbacks, child
#: and customization scripts.
SCRIPTS_SHARE = 0.5
#: Seconds of the server's CPU time (``time.process_time``, not wall time: a busy machine that
#: deschedules the server does not change the outcome) over which SCRIPTS_SHARE is counted: a
#: burst of up to SCRIPTS_SHARE x SCRIPTS_SHARE_WINDOW = 5 s of long passes is let through.
SCRIPTS_SHARE_WINDOW = 10.0
#: Bytes all of a scene's Lua script states may hold together (each at most MAX_SCRIPT_MEMORY).
MAX_SCRIPTS_MEMORY = 512 << 20
#: Distinct ports the scripts may ask the legacy remote API to serve with simExtRemoteApiStart /
#: simRemoteApi.start (those the server listens on already count once asked for; the others stay
#: open while the server runs, on the server's own hosts).
MAX_SCRIPT_PORTS = 8

# ----------------------------------------------------------------- child scripts' scene edits
# (the CoppeliaSim 4.x calls on scene objects, simx_server/api/sim/objects.py)
#: Longest object name a child script may give with ``sim.setObjectName``/``sim.setObjectAlias``
#: (V-REP's names are short; each name is kept in the scene's MjSpec and in every reply that
#: lists names). Scene growth from ``sim.createDummy`` is bounded by MAX_SCENE_ELEMENTS.
MAX_SCRIPT_OBJECT_NAME = 128
#: Largest force (N) and torque (N·m) component that scripts may add to a body for one step
#: (``sim.addForce``/``sim.addForceAndTorque``, summed over the step), as MAX_JOINT_FORCE bounds
#: a joint's: far beyond any robot, small enough for MuJoCo's arithmetic.
MAX_SCRIPT_FORCE = 1e8

# ------------------------------------------------- joint motors (motors.py)
#: Largest proportional gain of a joint's position loop (``sim_jointfloatparam_pid_p``, 2002, in
#: V-REP's units: the loop asks P x error per 5 ms). 1 asks the whole error in one V-REP
#: dynamics step; simx's loop gain is P / 5 ms, capped at 1/dt in any case.
MAX_PID_P = 1.0

# ----------------------------------------------------------------- vision sensors
#: s the simulation thread waits for the render thread to make a scene's renderers (GL
#: contexts and one warm-up frame per sensor) when the server starts and when a scene loads or
#: changes while the simulation is stopped; past it the simulation goes on and the first images
#: come later. A software renderer needs about 0.2-0.5 s for the bundled scene.
VISION_READY_TIMEOUT = 10.0
#: s any caller waits for a frame of a render thread (an image call, a sensor's handling, a
#: PyRep capture) and a closing simulation for its render threads to end; past it the call
#: raises ``RenderError`` (a GL driver that never returns). A 4096x4096 frame takes 1.5 s on
#: llvmpipe, ten times that on a loaded machine.
RENDER_WAIT_SECONDS = 120.0
#: s a stopping server waits for the background job threads (planning, convex decomposition,
#: scene conversions) to end before the interpreter exits; a job still running past it is left.
JOBS_SETTLE_TIMEOUT = 2.0

# ---------------------------------------------------------------------------------------------
# Inverse kinematics and imported shapes (simx_server/sim/ik.py, simx_server/scripts/shapes.py)
# ---------------------------------------------------------------------------------------------

#: Most solver iterations an IK group may declare (``simx:ik:NAME ... iterations=N``): each is
#: one mj_kinematics + mj_jacSite on the chain, solved every simulation step.
MAX_IK_ITERATIONS = 100
#: Most configurations one ``sim.generateIkPath`` computes: each is one resolution of the group
#: (at most MAX_IK_ITERATIONS iterations) on the simulation thread.
MAX_IK_PATH_POINTS = 1000
#: Largest mesh file ``sim.importShape`` reads (bytes): a scene script imports what a client
#: names, and MuJoCo reads the whole file.
MAX_IMPORT_BYTES = 16 * 1024 * 1024
#: Viewer model queries (``<prefix>/viewer/model``, simx-viewer) waiting for the simulation
#: thread, all viewers together; more are answered "server busy" at once. Each answer is the
#: whole compiled model (cached until the model changes), so a flood must not pile them up.
MAX_VIEWER_QUERIES = 16
#: Viewer model answers per second, all viewers together (a token bucket holding at most
#: MAX_VIEWER_QUERIES): each answer copies the whole compiled model (about 1 MB for the bundled
#: scene) on the simulation thread, and 16 query loops pulled 5.7 GB in 20 s, taking another
#: client's p99 from 17 ms to 1 s. A viewer asks once when it opens and once per new model
#: generation; the excess is answered "server busy" at once, naming this bound.
MAX_VIEWER_MODELS_PER_SECOND = 4.0

# ----------------------------------------------------------------- the ZMQ remote API
# (simx_server/zmq: frontend.py, the socket thread; service.py, the simulation thread). The ZMQ
# door has the legacy door's bounds (MAX_REQUEST_*, MAX_REPLY_BYTES, EDIT_SHARE, MAX_CLIENTS, the
# script-call bounds above); these are its own. docs/SECURITY.md explains each one.

#: Tables (Lua) or containers (Python) passed to one script function, at any depth (both
#: doors; a ZMQ sim.callScriptFunction may nest them): a million empty tables in a 1 MiB
#: request took the simulation thread 13 s to convert.
MAX_SCRIPT_CALL_TABLES = 1 << 16
#: Bytes of one ZMQ connection's replies that the kernel has not taken yet (a peer that asks
#: and does not read): past it, its next request answers "server busy". One largest reply
#: (MAX_REPLY_BYTES) fits. One connection asking for a 16 MiB signal every 20 ms, never
#: reading, grew the server by 3.3 GB in 13 s. A reply still rendering (an image call,
#: zmq/renders.py) counts from the call on: past the bound the call is refused before it renders.
MAX_ZMQ_UNSENT_BYTES = 96 * 1024 * 1024
#: The same, all ZMQ connections together: past it, every connection with unsent replies is
#: busy, and so is an image call of any connection.
MAX_ZMQ_UNSENT_BYTES_TOTAL = 256 * 1024 * 1024
#: ZMQ connections at once (as Redis's maxclients); the server also keeps it under half its
#: open-files limit (raised to the hard limit at start), so that Zenoh's clients always find
#: descriptors: 986 idle ZMQ connections made a new legacy client fail (limit 1,024).
MAX_ZMQ_CONNECTIONS = 1000
#: s a new ZMQ connection has to finish ZMTP's handshake (libzmq's ``ZMQ_HANDSHAKE_IVL``, 30 s by
#: default) before it is closed. Only connections let through by the ZAP handler (or open longer
#: than this) count toward MAX_ZMQ_CONNECTIONS: 1,100 TCP connections that never started it (each holding a slot for
#: libzmq's 30 s) left 1 of 8 new ZMQ clients served. A handshake on loopback takes about a
#: millisecond, CURVE's a few more round trips, but each waits for the ZAP handler, which runs on
#: the socket thread (Python): 3 s let 200 handshakes at once time out again and again on a
#: loaded machine while the server started.
ZMQ_HANDSHAKE_SECONDS = 10.0
#: s between the ZMTP heartbeat's PINGs the server sends every ZMQ connection, and s after a PING
#: within which a whole message (a PONG, a request) must come from it, else it is closed and its
#: half-received message freed (libzmq's ``ZMQ_HEARTBEAT_IVL``, ``ZMQ_HEARTBEAT_TIMEOUT``). A
#: client's libzmq answers PINGs by itself; a message must arrive within the timeout (the
#: largest, sockets.MAX_MESSAGE_BYTES, at about 8 Mbit/s).
ZMQ_HEARTBEAT_SECONDS = 5.0
ZMQ_HEARTBEAT_TIMEOUT_SECONDS = 20.0
#: The share of the machine's memory (or its cgroup's limit) that ZMQ messages still being
#: received may hold, each up to the largest message: it bounds the connections served at once
#: (zmq/sockets.py: 1,000 connections x 66 MiB allowed 66 GB).
ZMQ_RECEIVING_MEMORY_SHARE = 0.25
#: s a new Zenoh connection to the legacy door has to finish Zenoh's handshake (its
#: ``transport/unicast/accept_timeout``, 10 s by default), and handshakes under way at once
#: (``transport/unicast/accept_pending``, 100 by default; at most a third of the open-files
#: limit): Zenoh closes a connection beyond at once, the newest. An operator's Zenoh config file
#: that sets either key keeps its own value.
ZENOH_ACCEPT_SECONDS = 5.0
ZENOH_ACCEPT_PENDING = 16384
#: s between two sweeps of the legacy port's connections that are not a Zenoh session yet:
#: beyond a quarter of accept_pending of them, simx closes the oldest (legacy/handshakes.py), so
#: that a slot stays free for a new client's handshake while one process holds more idle
#: connections than that (Zenoh itself would refuse the newest once its slots are full).
ZENOH_SWEEP_SECONDS = 0.2
#: s a running simulation's pass keeps serving ZMQ requests, per client served in it, before its
#: step (CoppeliaSim's ZMQ remote API add-on: ``msgQueueTimeout_running``; Loop.hold_pass).
ZMQ_PASS_WINDOW = 0.002
#: Passes per s of wall time of a scene saved "not real time" (its asynchronous mode) when
#: ``--speed`` is not given: the pace its users saw in CoppeliaSim's window, which renders the
#: scene after every pass while simulating, sleeping nowhere (simThread.cpp
#: ``CSimThread::_idleSleepAndCheckIfRenderRequired``, passes per rendering 1), the rendered
#: frame's buffer swap waiting for a 60 Hz display. ``--speed 0`` is CoppeliaSim's headless pace
#: instead (``-h``: nothing rendered, as fast as possible).
DISPLAY_FRAME_RATE = 60.0
#: ZMQ clients (uuids) one connection may hold: the official client uses one per connection;
#: one connection took all MAX_CLIENTS slots with 1,100 stepping uuids in 0.4 s.
MAX_ZMQ_CLIENTS_PER_CONNECTION = 8
