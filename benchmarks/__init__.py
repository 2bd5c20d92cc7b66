"""simx benchmarks: measurements, not tests (see benchmarks/README.md).

Run everything with ``python -m benchmarks.run`` (``--quick`` for a smoke run).
"""
