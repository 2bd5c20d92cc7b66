"""simx server: a MuJoCo simulation served over V-REP's legacy remote API (``simx-server``).

Packages are layers; imports point down only (docs/ARCHITECTURE.md, tests/test_layers.py):
``cli``/``pool`` -> ``legacy`` | ``zmq`` (the front doors) -> ``loop`` -> ``commands`` -> ``scene`` -> ``scripts`` -> ``sim`` -> ``base``.
"""

#: The version of the ``simx`` distribution: pyproject.toml reads it from here (setuptools'
#: dynamic version), ``simx-server --version`` prints it.
__version__ = "0.1.0"
