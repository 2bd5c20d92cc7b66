"""Imported last by the test servers' forkserver (tests/server_fork.py, ``PRELOAD``): what it has
imported moves to the collector's permanent generation (``gc.freeze``), so that a forked
server's collections (``simx-server`` collects and freezes once at start) do not walk, and so
copy, the pages of the objects it shares with the forkserver."""

import gc

gc.collect()
gc.freeze()
