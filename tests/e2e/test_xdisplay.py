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
import time

import pytest

try:
    from xdisplay import VirtualDisplay, find_window, send_keys
except ImportError:  # tests/ imported as a package
    from tests.xdisplay import VirtualDisplay, find_window, send_keys

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
            t0 = time.monotonic()
            try:
                out, err = proc.communicate(timeout=10)
            except subprocess.TimeoutExpired:
                fail("probe did not exit within 10 s of the keys being sent")
            elapsed = time.monotonic() - t0
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    lines = out.splitlines()
    assert proc.returncode == 0, f"probe exit {proc.returncode}\nstdout:\n{out}\nstderr:\n{err}"
    assert lines == ["ready", "key q", "key q", "key space", "key p"], (
        f"stdout:\n{out}\nstderr:\n{err}"
    )
    assert elapsed < 10


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


def test_find_window_times_out_with_clear_error():
    with VirtualDisplay() as xd:
        t0 = time.monotonic()
        with pytest.raises(RuntimeError, match="no visible window"):
            find_window(xd.display, "no such window title", timeout=0.5)
        assert time.monotonic() - t0 < 5
