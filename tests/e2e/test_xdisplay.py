"""Proves the Xvfb + xdotool harness in tests/e2e/xdisplay.py delivers real key events.

A tiny pygame program runs on a private Xvfb display; the test finds its
window, types "q q space p" with xdotool, and checks that the program saw
exactly those KEYDOWN events, in order, and exited 0 on "p".
"""

import os
import shutil
import subprocess
import sys
import textwrap
import types

import pytest

import xdisplay as xdisplay_module
from xdisplay import VirtualDisplay, find_window, send_keys

pytestmark = pytest.mark.skipif(
    shutil.which("Xvfb") is None or shutil.which("xdotool") is None,
    reason="needs Xvfb and xdotool: run `scripts/system-deps.sh --with-x`",
)

TITLE = "xdisplay probe"

PROBE = textwrap.dedent(
    """
    import sys
    import pygame

    pygame.display.init()
    screen = pygame.display.set_mode((320, 240))
    pygame.display.set_caption(%r)
    print("ready", flush=True)
    clock = pygame.time.Clock()
    while True:
        for event in pygame.event.get():
            if event.type == pygame.QUIT:
                sys.exit(3)
            if event.type == pygame.KEYDOWN:
                print("key", pygame.key.name(event.key), flush=True)
                if event.key == pygame.K_p:
                    pygame.quit()
                    sys.exit(0)
        screen.fill((40, 40, 40))
        pygame.display.flip()
        clock.tick(60)
    """
    % TITLE
)


def test_keys_reach_pygame_window(tmp_path):
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    with VirtualDisplay() as xd:
        assert xd.display.startswith(":")
        env = xd.env()
        env["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"
        proc = subprocess.Popen(
            [sys.executable, str(script)],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        def fail(why):
            proc.kill()
            out, err = proc.communicate()
            pytest.fail(f"{why}\nprobe exit {proc.returncode}\nstdout:\n{out}\nstderr:\n{err}")

        try:
            try:
                wid = find_window(xd.display, TITLE, timeout=20.0)
                send_keys(xd.display, wid, "q", "q", "space", "p")
            except RuntimeError as exc:
                fail(exc)
            try:  # a bound on the wait only: the probe exits on "p"
                out, err = proc.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                fail("probe did not exit within 30 s of the keys being sent")
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    lines = out.splitlines()
    assert proc.returncode == 0, f"probe exit {proc.returncode}\nstdout:\n{out}\nstderr:\n{err}"
    assert lines == ["ready", "key q", "key q", "key space", "key p"], (
        f"stdout:\n{out}\nstderr:\n{err}"
    )


def test_virtual_display_close_is_idempotent():
    xd = VirtualDisplay()
    pid = xd.pid
    env = xd.env({"SDL_VIDEODRIVER": "dummy", "FOO": "1"})
    assert env == {"DISPLAY": xd.display, "SDL_VIDEODRIVER": "x11", "FOO": "1"}
    xd.close()
    xd.close()
    # The Xvfb process is gone (and reaped).
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_find_window_times_out_with_clear_error(monkeypatch):
    """find_window polls until its timeout has passed on its clock, then raises: here a clock
    that moves only by its 50 ms sleeps, so the count of searches is exact on any machine
    (0.5 s: 11 searches, one more where the float sum falls short; the default 20 s: 401)."""
    with VirtualDisplay() as xd:
        clock = [0.0]

        def sleep(seconds: float) -> None:
            clock[0] += seconds

        searches = []
        xdotool = xdisplay_module._xdotool

        def counting_xdotool(display: str, *args: str, **kwargs):
            if args[0] == "search":
                searches.append(clock[0])
            return xdotool(display, *args, **kwargs)

        monkeypatch.setattr(xdisplay_module, "time", types.SimpleNamespace(monotonic=lambda: clock[0], sleep=sleep))
        monkeypatch.setattr(xdisplay_module, "_xdotool", counting_xdotool)
        with pytest.raises(RuntimeError, match=r"no visible window .* within 0\.5 s"):
            find_window(xd.display, "no such window title", timeout=0.5)
        assert len(searches) in (11, 12) and searches[-1] >= 0.5 - 1e-9, searches
