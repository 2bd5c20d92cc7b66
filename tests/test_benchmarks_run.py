"""``python -m benchmarks.run`` says which suites could not run, and its exit status fails CI for
them (issue 60: the image suites had stopped running, and a run of them still ended with status
0): a suite that raises, or skips a figure for a reason of its own, fails the run; a suite that
needs a package this machine lacks says so and does not. The suites themselves run in CI in
their tiniest form (``scripts/bench-smoke.sh``, run by ``.ci/run``), not here."""

from __future__ import annotations

import json
import sys

import pytest

from benchmarks import run
SUITES = {
    "fine": "def run(s):\n    return [Figure('fine.x', 'a figure', 'ms', summary([1.0, 2.0]))]\n",
    "broken": "def run(s):\n    raise RuntimeError('simxStart to 127.0.0.1:1 failed')\n",
    "gives_up": "def run(s):\n    return [skipped('gives_up.x', 'a figure', 'no frame within 90 s')]\n",
    "no_package": "import not_a_package_here_60\n\ndef run(s):\n    return []\n",
    "no_xvfb": "def run(s):\n    return [unavailable('no_xvfb.x', 'a figure', 'Xvfb not installed')]\n",
    "own_import": "from simx_client import not_a_module_60\n\ndef run(s):\n    return []\n",
}


@pytest.fixture
def fake_suites(tmp_path, monkeypatch):
    folder = tmp_path / "fake_suites_60"
    folder.mkdir()
    for name, body in SUITES.items():
        (folder / f"{name}.py").write_text("from benchmarks.stats import Figure, skipped, summary, unavailable\n" + body)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(run, "SUITES", {name: (f"fake_suites_60.{name}", name) for name in SUITES})
    monkeypatch.setattr(run, "OPT_IN", set())
    monkeypatch.setattr(run, "RESULTS", tmp_path / "results")
    monkeypatch.setattr(run.procs, "SERVER_ARGS", [])  # --smoke sets it for the run's servers
    yield tmp_path
    for name in list(sys.modules):
        if name.startswith("fake_suites_60"):
            del sys.modules[name]


def _main(tmp_path, only: str) -> tuple[int, dict]:
    out = tmp_path / "out.json"
    status = run.main(["--smoke", "--only", only, "--out", str(out)])
    return status, json.loads(out.read_text())


@pytest.mark.parametrize("only", ["broken", "gives_up", "own_import", "fine,broken,no_package"])
def test_a_suite_that_cannot_run_fails_the_run_and_is_named(fake_suites, capsys, only):
    status, doc = _main(fake_suites, only)
    err = capsys.readouterr().err
    assert status == 1
    failing = [n for n in only.split(",") if n in ("broken", "gives_up", "own_import")]
    for name in failing:
        assert f"FAILED: {name}" in err, err
    assert "could not run" in err and "FAILED: fine" not in err
    assert doc["meta"]["mode"] == "smoke"


def test_a_missing_optional_package_or_program_is_said_and_does_not_fail(fake_suites, capsys):
    status, doc = _main(fake_suites, "fine,no_package,no_xvfb")
    err = capsys.readouterr().err
    assert status == 0, err
    assert "not available here: no_package.error: SKIPPED (not available here): needs the not_a_package_here_60 " \
           "package" in err
    assert "not available here: no_xvfb.x: SKIPPED (not available here): Xvfb not installed" in err
    assert "FAILED" not in err
    rows = {f["key"]: f for f in doc["figures"]}
    assert rows["fine.x"]["stats"]["median"] == 1.5 and rows["no_xvfb.x"]["unavailable"]

