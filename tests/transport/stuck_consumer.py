"""A client that asks for a lot and then stops reading (tests/transport/test_slow_consumer.py):
16 viewer model queries and 60 RGB images of the Kinect, sent without waiting, then it prints
"sent" and waits to be stopped (SIGSTOP) by the test.

    python stuck_consumer.py PORT
"""

import sys
import time
import uuid

import zenoh

from simx_client import protocol as P
from simx_client.connection import client_config

port = int(sys.argv[1])
session = zenoh.open(client_config("127.0.0.1", port))
me = uuid.uuid4().hex
ignore = zenoh.handlers.Callback(lambda reply: time.sleep(1), indirect=False)  # a slow reader
handle = None
for reply in session.get(P.call_key(P.DEFAULT_PREFIX, me), timeout=10,
                         payload=P.request(me, [["GetObjectHandle", P.MODE_BLOCKING, ["kinect_rgb"]]])):
    handle = P.unpack_response(reply.ok.payload.to_bytes())[5][0][1]
for _ in range(16):
    session.get(P.viewer_model_key(), ignore, timeout=60)
for _ in range(60):
    session.get(P.call_key(P.DEFAULT_PREFIX, me), ignore, timeout=60,
                payload=P.request(me, [["GetVisionSensorImage", P.MODE_BLOCKING, [handle, 0]]]))
print("sent", flush=True)
time.sleep(600)
