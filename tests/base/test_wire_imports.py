"""scripts/wire_imports.py: the mechanical rewrite of simx_client's wire imports to simx_wire."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "wire_imports.py"
_spec = importlib.util.spec_from_file_location("wire_imports", SCRIPT)
assert _spec is not None and _spec.loader is not None
wire_imports = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(wire_imports)


def test_rewrite_moves_only_the_wire_modules() -> None:
    before = (
        "from simx_client import constants as C\n"
        "from simx_client import protocol as P, decoded_size\n"
        "    from simx_client.protocol import ArgumentError, RemoteError\n"
        "import simx_client.legacy_constants\n"
        "from simx_client import api\n"
        "from simx_client.connection import client_config\n"
        '"""Errors are :class:`simx_client.protocol.RemoteError`."""\n'
    )
    after = (
        "from simx_wire import constants as C\n"
        "from simx_wire import protocol as P, decoded_size\n"
        "    from simx_wire.protocol import ArgumentError, RemoteError\n"
        "import simx_wire.legacy_constants\n"
        "from simx_client import api\n"
        "from simx_client.connection import client_config\n"
        '"""Errors are :class:`simx_wire.protocol.RemoteError`."""\n'
    )
    assert wire_imports.rewrite(before) == after
    assert wire_imports.rewrite(after) == after


def test_the_tree_needs_no_rewrite() -> None:
    out = subprocess.run([sys.executable, str(SCRIPT), "--check"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
