"""Write docs/COVERAGE.md from the code (simx_server/zmq/coverage.py): every function of
CoppeliaSim 4.x's sim and simIK tables with simx's status. Run after adding a function."""

from __future__ import annotations

from pathlib import Path

from simx_server.zmq.coverage import markdown

if __name__ == "__main__":
    out = Path(__file__).resolve().parents[1] / "docs" / "COVERAGE.md"
    out.write_text(markdown() + "\n", encoding="utf-8")
    print(f"wrote {out}")
