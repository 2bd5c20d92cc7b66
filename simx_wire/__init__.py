"""The legacy remote API's wire schema, shared by simx's server and client and owned by neither.

* :mod:`simx_wire.protocol`: key expressions, message shapes, the msgpack codec, command names
  and their identifying arguments, and the exception hierarchy both sides raise;
* :mod:`simx_wire.constants`: every legacy ``simx_*`` / ``sim_*`` constant with its V-REP /
  CoppeliaSim value, built from the generated table :mod:`simx_wire.legacy_constants`;
* :mod:`simx_wire.decoded_size`: what a msgpack payload costs once decoded, measured on its
  bytes before decoding (the server's memory budget for requests).

Layer: below both sides. It imports only the standard library and msgpack, never
``simx_server`` nor ``simx_client`` (``tests/test_layers.py`` checks it). ``simx_client`` keeps
these modules importable under their old names (``from simx_client import protocol`` and
the like). docs/PROTOCOL.md describes the same schema for other languages.
"""
