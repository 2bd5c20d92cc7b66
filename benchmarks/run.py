"""Run the simx benchmarks, print the table and write it as JSON.

    python -m benchmarks.run            # everything, a few minutes on 2 cores
    python -m benchmarks.run --quick    # smoke run, under a minute
    python -m benchmarks.run --only calls,images --tag gpu
    python -m benchmarks.run --only robustness [--quick]   # opt-in: floods and soaks a server
    python -m benchmarks.run --smoke    # every suite, tiny: that each runs (CI), no figure meant

Every figure is a median over many repetitions with its p10/p90 (and min/max in the JSON);
every comparison is a ratio to a floor measured side by side in the same run.
Results: benchmarks/results/latest.json (and a timestamped copy; --smoke: smoke.json only), server
logs in benchmarks/results/logs/. Exit status 1 when a suite failed (its row says SKIPPED and why),
or skipped a figure for another reason than something optional this machine lacks.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib
import json
import math
import os
import platform
import subprocess
import sys
import time
import traceback
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

from benchmarks.common import Settings, loadavg  # noqa: E402
from benchmarks import procs  # noqa: E402
from benchmarks.procs import ROOT  # noqa: E402
from benchmarks.stats import Figure, skipped, unavailable  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
#: suite name -> (module, what it measures), in the order they run.
SUITES = {
    "calls": ("benchmarks.calls", "1. call round trip"),
    "streaming": ("benchmarks.streaming", "2. streaming"),
    "images": ("benchmarks.images", "3. images"),
    "sync": ("benchmarks.sync", "4. synchronous stepping"),
    "physics": ("benchmarks.physics", "5. physics speed"),
    "clients": ("benchmarks.clients", "6. many clients"),
    "tutorial": ("benchmarks.tutorial", "7. the tutorial loop"),
    "pacing": ("benchmarks.pacing", "pacing of blocking calls: legacy and immediate (issue 12)"),
    "robustness": ("benchmarks.robustness", "8. robustness (issue 11)"),
    "dataset": ("benchmarks.dataset", "9. simx-dataset images per second (issue 13)"),
    "envs": ("benchmarks.envs", "Gymnasium env steps/s, remote vs in-process (issue 13)"),
    "envstep": ("benchmarks.env_step", "one env's step, remote and in-process interleaved (issue 44)"),
    "idle": ("benchmarks.idle", "idle servers cost nothing: an env beside 3 idle servers (issue 20)"),
    "outbox": ("benchmarks.outbox", "command batching: a loop of oneshot calls on the wire (issue 19)"),
    "zmq": ("benchmarks.zmq_api", "CoppeliaSim's ZMQ remote API: against bare REQ/REP and the legacy API (issue 22)"),
    "startup": ("benchmarks.startup", "start-up refusals: a taken port said at once (issue 60)"),
}
#: A suite that cannot import one of these is broken; any other missing module is a package this
#: machine lacks (the suite's row says which).
OWN_PACKAGES = {"benchmarks", "simx_wire", "simx_client", "simx_server", "simx_viewer", "pyrep", "tests"}
#: Suites run only when named in --only: the robustness suite floods a server on purpose and
#: soaks it for 3 minutes (about 5 minutes in all), which the everyday run should not do; the
#: envs suite starts up to 4 servers at once and takes a few minutes of 640x480 renders.
OPT_IN = {"robustness", "envs", "envstep", "idle"}


def _fmt(v, unit: str = "") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    a = abs(v)
    if a >= 1000:
        s = f"{v:,.0f}"
    elif a >= 100:
        s = f"{v:.0f}"
    elif a >= 10:
        s = f"{v:.1f}"
    elif a >= 1:
        s = f"{v:.2f}"
    else:
        s = f"{v:.3f}"
    return s


def table(figures: list[Figure]) -> str:
    head = ["figure", "unit", "median", "p10", "p90", "floor", "ratio", "target", "met?"]
    rows = [head]
    for f in figures:
        st = f.stats
        floor = f.floor["median"] if f.floor else None
        met = {True: "yes", False: "NO", None: ""}[f.met]
        rows.append([f.label, f.unit, _fmt(st["median"]), _fmt(st["p10"]), _fmt(st["p90"]), _fmt(floor),
                     "" if f.ratio is None else f"{f.ratio:.2f}x", f.target.describe() if f.target else "", met])
        if f.note.startswith("SKIPPED"):
            rows[-1][2] = f.note
    widths = [max(len(r[i]) for r in rows if not (r[2].startswith("SKIPPED") and i == 2)) for i in range(len(head))]
    widths[0] = min(widths[0], 56)
    out = []
    for k, r in enumerate(rows):
        if r[2].startswith("SKIPPED"):
            out.append(f"{r[0][:widths[0]]:<{widths[0]}}  {r[2]}")
            continue
        cells = [f"{r[0][:widths[0]]:<{widths[0]}}", f"{r[1]:<{widths[1]}}"]
        cells += [f"{c:>{w}}" for c, w in zip(r[2:7], widths[2:7])]
        cells += [f"{r[7]:<{widths[7]}}", r[8]]
        out.append("  ".join(cells).rstrip())
        if k == 0:
            out.append("-" * len(out[0]))
    return "\n".join(out)


def _git_commit() -> str:
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                                text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return commit + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.run", description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="short run (fewer repetitions)")
    p.add_argument("--smoke", action="store_true",
                   help="every suite (the opt-in ones too, unless --only or --skip) in its tiniest form, to show that "
                        "each runs (CI: scripts/bench-smoke.sh); none of its figures means anything")
    p.add_argument("--only", help=f"comma-separated suites to run: {','.join(SUITES)}")
    p.add_argument("--skip", help="comma-separated suites to leave out")
    p.add_argument("--tag", default="", help="label stored in the JSON and its file name (e.g. gpu)")
    p.add_argument("--out", type=Path, help="JSON output path (default benchmarks/results/latest.json)")
    p.add_argument("--baseline", type=Path,
                   help="another simx source tree (e.g. `git archive <commit> | tar -x -C DIR`) whose server "
                        "the sync and envstep suites time side by side with this tree's")
    args = p.parse_args(argv)

    only = [x for x in (args.only or "").split(",") if x]
    skip = {x for x in (args.skip or "").split(",") if x}
    unknown = [x for x in [*only, *skip] if x not in SUITES]
    if unknown:
        p.error(f"unknown suite(s) {unknown}; choose from {list(SUITES)}")
    names = [n for n in (only or [n for n in SUITES if args.smoke or n not in OPT_IN]) if n not in skip]

    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    log_dir = RESULTS / "logs" / stamp
    if args.baseline is not None and not (args.baseline / "simx_server" / "cli.py").is_file():
        p.error(f"--baseline {args.baseline}: not a simx source tree (no simx_server/cli.py)")
    settings = Settings(quick=args.quick or args.smoke, log_dir=log_dir, baseline=args.baseline, smoke=args.smoke)
    if args.smoke:
        procs.SERVER_ARGS[:] = ["--renderers", "on-demand"]
    meta = {
        "started": _dt.datetime.now().isoformat(timespec="seconds"),
        "mode": "smoke" if args.smoke else "quick" if args.quick else "full",
        "tag": args.tag,
        "commit": _git_commit(),
        "baseline": str(args.baseline) if args.baseline else None,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "mujoco_gl": os.environ.get("MUJOCO_GL"),
        "loadavg_start": loadavg(),
        "suites": {},
    }
    figures: list[Figure] = []
    t_start = time.monotonic()
    for name in names:
        module, title = SUITES[name]
        print(f"== {title} ...", file=sys.stderr, flush=True)
        t0, cpu0 = time.monotonic(), _cpu_s()
        try:
            got = importlib.import_module(module).run(settings)
            status = "ok"
        except Exception as exc:  # one broken suite must not hide the others' figures
            missing = exc.name if isinstance(exc, ModuleNotFoundError) else None
            if missing and missing.split(".")[0] not in OWN_PACKAGES:  # a package this machine lacks
                got = [unavailable(f"{name}.error", title,
                                   f"needs the {missing} package, not installed here (pip install -e '.[test,bench]')")]
                status = f"not available: no {missing} package"
            else:
                traceback.print_exc()
                got = [skipped(f"{name}.error", title, f"{type(exc).__name__}: {exc}")]
                status = f"error: {exc}"
        figures.extend(got)
        cpu = _cpu_s() - cpu0
        meta["suites"][name] = {"seconds": round(time.monotonic() - t0, 1), "cpu_s": round(cpu, 1),
                                "status": status, "loadavg_after": loadavg()}
        print(f"   {name}: {time.monotonic() - t0:.1f} s ({cpu:.1f} s of CPU)", file=sys.stderr, flush=True)
    meta["seconds"] = round(time.monotonic() - t_start, 1)
    meta["cpu_s"] = round(sum(x["cpu_s"] for x in meta["suites"].values()), 1)
    meta["loadavg_end"] = loadavg()

    text = table(figures)
    print(text)
    print(f"\n{meta['mode']} run, {meta['seconds']} s ({meta['cpu_s']} s of CPU), commit {meta['commit']}, "
          f"load average {meta['loadavg_start']} -> {meta['loadavg_end']}")
    for f in figures:
        if f.note and not f.note.startswith("SKIPPED"):
            print(f"  {f.key}: {f.note}")
    doc = _clean({"meta": meta, "figures": [f.as_dict() for f in figures], "table": text})
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = args.out or RESULTS / ("smoke.json" if args.smoke else "latest.json")
    body = json.dumps(doc, indent=1, allow_nan=False)
    out.write_text(body)
    if not args.smoke:
        (RESULTS / f"run-{stamp}{'-' + args.tag if args.tag else ''}.json").write_text(body)
    _prune(RESULTS / "logs", keep=5)
    print(f"\nwritten: {out}")
    return _verdict(meta, figures)


def _verdict(meta: dict, figures: list[Figure]) -> int:
    """The exit status: 1 when a suite failed or a figure was skipped for another reason than
    something optional this machine lacks (each named on stderr), else 0."""
    missing = [f for f in figures if f.unavailable]
    for f in missing:
        print(f"not available here: {f.key}: {f.note}", file=sys.stderr)
    broken = [name for name, info in meta["suites"].items() if info["status"].startswith("error")]
    failed = [f"{name}: {meta['suites'][name]['status']}" for name in broken]
    failed += [f"{f.key}: {f.note}" for f in figures  # a suite's own SKIPPED row is its status, said above
               if f.note.startswith("SKIPPED") and not f.unavailable and f.key not in {f"{n}.error" for n in broken}]
    for line in failed:
        print(f"FAILED: {line}", file=sys.stderr)
    if failed:
        print(f"benchmarks.run: {len(failed)} suite(s) or figure(s) could not run (see above)", file=sys.stderr)
    return 1 if failed else 0


def _cpu_s() -> float:
    """CPU seconds (user + system) of this process and of its children that have ended (every
    server, echo and worker a suite starts is waited for by the suite)."""
    import resource

    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _clean(value):
    """JSON-safe: NaN/inf -> None, numpy scalars -> Python, tuples -> lists."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _prune(logs: Path, keep: int) -> None:
    """Keep only the newest ``keep`` run log folders (client latency files add up)."""
    import shutil

    if logs.is_dir():
        for old in sorted(p for p in logs.iterdir() if p.is_dir())[:-keep]:
            shutil.rmtree(old, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
