"""scripts/suite_total.py: the whole suite's total from scripts/test.sh's two pytest runs, each
test counted once (a module skipped at import is reported by both runs)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

TESTS = '''
import pytest

def test_passes():
    pass

def test_fails():
    assert False

def test_skips():
    pytest.skip("no reason")

@pytest.mark.xfail(reason="known")
def test_xfails():
    assert False

@pytest.mark.ray
def test_ray_passes():
    pass
'''


def _pytest(folder: Path, report: Path, marker: str) -> int:
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                           "-c", str(folder / "pytest.ini"), "--rootdir", str(folder), "-m", marker,
                           f"--junitxml={report}", str(folder)],
                          capture_output=True, text=True, timeout=120, cwd=folder).returncode


def test_the_total_of_two_runs_counts_each_test_once(tmp_path):
    (tmp_path / "pytest.ini").write_text("[pytest]\nmarkers =\n    ray: the run of its own\n")
    (tmp_path / "test_a.py").write_text(TESTS)
    (tmp_path / "test_b.py").write_text('import pytest\npytest.skip("no extra", allow_module_level=True)\n')
    assert _pytest(tmp_path, tmp_path / "main.xml", "not ray") == 1  # a test failed
    assert _pytest(tmp_path, tmp_path / "ray.xml", "ray") == 0
    out = subprocess.run([sys.executable, str(ROOT / "scripts" / "suite_total.py"), str(tmp_path / "main.xml"),
                          str(tmp_path / "ray.xml")], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    # both runs report test_b.py's skip; the second run's own count would be "1 passed, 1 skipped"
    assert out.stdout.splitlines()[-1] == "2 passed, 1 failed, 2 skipped, 1 xfailed"


def test_a_missing_report_is_named_and_the_rest_counted(tmp_path):
    (tmp_path / "main.xml").write_text('<testsuites><testsuite name="pytest" tests="1">'
                                       '<testcase classname="test_a" name="test_ray_passes" time="0.001"/>'
                                       '</testsuite></testsuites>')
    out = subprocess.run([sys.executable, str(ROOT / "scripts" / "suite_total.py"), str(tmp_path / "main.xml"),
                          str(tmp_path / "gone.xml")], capture_output=True, text=True, timeout=60)
    lines = out.stdout.splitlines()
    assert f"no test report {tmp_path / 'gone.xml'}" in lines[0]
    assert lines[-1] == "1 passed, 0 failed, 0 skipped"
