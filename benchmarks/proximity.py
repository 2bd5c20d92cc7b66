"""The cost of asking a proximity sensor about one shape (``sim.checkProximitySensor``, PyRep's
``ProximitySensor.is_detected``), as RLBench's success conditions ask at every step.

Scene (made here, MJCF): a table, a V-REP pyramid volume sensor (``volume=pyramid``, 10 x 10 cm,
5 cm deep, as RLBench's ``success`` sensors) and 30 small shapes: boxes and capsules (both on
the exact triangle test; the capsules on their tessellation). Rows, µs per call (median; the cases interleaved
in shuffled blocks, ``benchmarks.common.interleaved``):

* ``far``: a shape 40 cm from the volume (most of RLBench's asks);
* ``inside``: a shape in the volume (detected);
* ``all``: the sensor's own reading of every detectable shape (``sim.readProximitySensor``).

Run the same file against two source trees to compare (the figures hold for one machine and
load; run both in one sitting)::

    PYTHONPATH=/path/to/old/tree MUJOCO_GL=egl python benchmarks/proximity.py
    PYTHONPATH=$PWD MUJOCO_GL=egl python benchmarks/proximity.py
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

SHAPES = 30


def scene() -> str:
    """The benchmark's scene, MJCF."""
    bodies = []
    for i in range(SHAPES):
        x, y = 0.4 + 0.05 * (i % 6), -0.15 + 0.06 * (i // 6)
        geom = 'type="box" size="0.02 0.02 0.02"' if i % 2 else 'type="capsule" size="0.015 0.02"'
        bodies.append(f'<body name="s{i}" pos="{x:.3f} {y:.3f} 0.02"><freejoint/><geom {geom}/></body>')
    bodies.append('<body name="inside" pos="0 0 0.03"><freejoint/><geom type="box" size="0.02 0.02 0.02"/></body>')
    return f"""<mujoco model="proximity_bench">
  <worldbody>
    <geom name="table" type="plane" size="1 1 0.05"/>
    <site name="success" pos="0 0 0.001"/>
    {''.join(bodies)}
  </worldbody>
  <sensor><rangefinder site="success" cutoff="0.05"/></sensor>
  <custom><text name="simx:success" data="volume=pyramid size=0.1,0.1 size_far=0.1,0.1"/></custom>
</mujoco>"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--per-round", type=int, default=40)
    args = ap.parse_args()
    from benchmarks.common import interleaved
    from simx_server.scene.simulation import Simulation
    from simx_server.sim import proximity

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.xml"
        path.write_text(scene())
        sim = Simulation(path, realtime=False)
        try:
            w = sim.world
            sensor = w.resolve("success").handle
            far, inside = w.resolve("s0").handle, w.resolve("inside").handle
            assert proximity.proximity_reading(sim, sensor, inside)[0] is True
            assert proximity.proximity_reading(sim, sensor, far)[0] is False
            rows = {
                "far": lambda: proximity.proximity_reading(sim, sensor, far),
                "inside": lambda: proximity.proximity_reading(sim, sensor, inside),
                "all": lambda: proximity.proximity_reading(sim, sensor),
            }
            for name, times in interleaved(args.rounds, args.per_round, rows).items():
                print(f"{name:8s} {statistics.median(times) * 1e6:9.1f} us per call")
        finally:
            sim.close()


if __name__ == "__main__":
    main()
