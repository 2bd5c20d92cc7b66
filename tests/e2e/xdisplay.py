"""Test helper: a private X server (Xvfb) and real keyboard input via xdotool.

Used by tests that need to drive an on-screen program (e.g. a pygame/SDL2
window) with genuine X key events, on a machine with no display.

Needs the ``Xvfb`` and ``xdotool`` executables; on Debian/Ubuntu install them
with ``scripts/system-deps.sh --with-x``.  Every failure to start or talk to
them raises :class:`RuntimeError` carrying the tool's stderr.

Typical use::

    with VirtualDisplay() as xd:
        proc = subprocess.Popen([...], env=xd.env())
        wid = find_window(xd.display, "my window title")
        send_keys(xd.display, wid, "q", "space")
"""

from __future__ import annotations

import os
import re
import select
import shutil
import socket
import subprocess
import tempfile
import time
from typing import Mapping, Optional

__all__ = [
    "FIX_HINT",
    "VirtualDisplay",
    "find_window",
    "have_x_tools",
    "send_keys",
]

FIX_HINT = "install them with `scripts/system-deps.sh --with-x` (Debian/Ubuntu packages xvfb, xdotool)"

# Per-call limit for each xdotool invocation, seconds.
_XDOTOOL_CALL_TIMEOUT_S = 10.0


def have_x_tools() -> bool:
    """Return True when both ``Xvfb`` and ``xdotool`` are on PATH."""
    return shutil.which("Xvfb") is not None and shutil.which("xdotool") is not None


class VirtualDisplay:
    """A private Xvfb X server on a display number it picks itself.

    Starts ``Xvfb -displayfd FD -screen 0 WxHxD -nolisten tcp -noreset``.
    With ``-displayfd`` the server chooses a free display number, claims its
    lock file itself (so parallel test processes cannot collide) and writes
    the number to the pipe ``FD`` only once it accepts connections; the
    constructor blocks on that pipe (up to ``startup_timeout`` seconds, no
    fixed sleeps) and then confirms by connecting to the server's Unix socket.

    Attributes:
        display: the X display name, e.g. ``":99"``.
        pid: process id of the Xvfb server this object started.

    Args:
        width, height: screen size in pixels.
        depth: colour depth in bits per pixel (24 for SDL/pygame).
        startup_timeout: seconds to wait for the server to become ready.

    Raises:
        RuntimeError: ``Xvfb`` is not installed, exits during start-up, or is
            not ready within ``startup_timeout`` (message includes its stderr).

    ``close()`` (also called on ``with`` exit and from ``__del__``) terminates
    only the Xvfb process it started, by PID, and is idempotent.
    """

    def __init__(self, width: int = 1024, height: int = 768, depth: int = 24,
                 startup_timeout: float = 15.0, fbdir: Optional[str] = None) -> None:
        self._proc: Optional[subprocess.Popen] = None
        self._stderr = None
        self.display: str = ""
        self.pid: Optional[int] = None

        xvfb = shutil.which("Xvfb")
        if xvfb is None:
            raise RuntimeError(f"Xvfb not found on PATH; {FIX_HINT}")

        # Xvfb's stderr goes to a temp file (a pipe could fill and block it).
        self._stderr = tempfile.TemporaryFile(prefix="xvfb-stderr-")
        read_fd, write_fd = os.pipe()
        cmd = [xvfb, "-displayfd", str(write_fd),
               "-screen", "0", f"{width}x{height}x{depth}",
               "-nolisten", "tcp", "-noreset"]
        self.fbdir = fbdir
        if fbdir is not None:  # the screen, memory-mapped in XWD format: screenshot() reads it
            cmd += ["-fbdir", fbdir]
        try:
            try:
                self._proc = subprocess.Popen(
                    cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                    stderr=self._stderr, pass_fds=(write_fd,),
                    start_new_session=True)  # keep terminal signals (Ctrl-C) to us
            except OSError as exc:
                raise RuntimeError(f"could not start Xvfb ({exc}); {FIX_HINT}") from exc
            finally:
                os.close(write_fd)  # our copy; EOF on read_fd if Xvfb dies
            self.pid = self._proc.pid
            number = self._read_display_number(read_fd, startup_timeout)
        except BaseException:
            os.close(read_fd)
            self.close()
            raise
        os.close(read_fd)
        self.display = f":{number}"
        try:
            self._wait_for_socket(number, startup_timeout)
        except BaseException:
            self.close()
            raise

    # -- start-up ---------------------------------------------------------

    def _read_display_number(self, fd: int, timeout: float) -> int:
        """Block until Xvfb writes ``N\\n`` to ``fd``; return N."""
        deadline = time.monotonic() + timeout
        data = b""
        while not data.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0:
                raise RuntimeError(
                    f"Xvfb not ready after {timeout:.1f} s; stderr:\n{self._stderr_text()}")
            ready, _, _ = select.select([fd], [], [], left)
            if not ready:
                continue
            chunk = os.read(fd, 64)
            if not chunk:  # EOF: Xvfb exited (or closed the fd) without a number
                rc = self._proc.wait(timeout=5) if self._proc else None
                raise RuntimeError(
                    f"Xvfb exited during start-up (exit status {rc}); stderr:\n"
                    f"{self._stderr_text()}")
            data += chunk
        try:
            return int(data.strip())
        except ValueError:
            raise RuntimeError(f"Xvfb wrote an unexpected display number {data!r}") from None

    def _wait_for_socket(self, number: int, timeout: float) -> None:
        """Confirm the server accepts connections on its Unix socket."""
        path = f"/tmp/.X11-unix/X{number}"
        deadline = time.monotonic() + timeout
        last_err: Optional[OSError] = None
        while time.monotonic() < deadline:
            if self._proc is not None and self._proc.poll() is not None:
                raise RuntimeError(
                    f"Xvfb exited (status {self._proc.returncode}); stderr:\n{self._stderr_text()}")
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
                try:
                    s.connect(path)
                    return
                except OSError as exc:
                    last_err = exc
            time.sleep(0.02)  # poll interval, not a fixed start-up delay
        raise RuntimeError(
            f"Xvfb on {self.display} not accepting connections on {path} after "
            f"{timeout:.1f} s ({last_err}); stderr:\n{self._stderr_text()}")

    def _stderr_text(self) -> str:
        if self._stderr is None or self._stderr.closed:
            return ""
        try:
            self._stderr.seek(0)
            return self._stderr.read().decode("utf-8", "replace").strip()
        except (OSError, ValueError):
            return ""

    # -- public API -------------------------------------------------------

    def screenshot(self):
        """The whole screen as a BGR ``uint8`` array of shape (height, width, 3) (OpenCV's
        layout), read from the XWD file Xvfb keeps of its screen (start with ``fbdir=``).

        Xvfb's ``-fbdir`` maps its frame buffer to ``<fbdir>/Xvfb_screen0``: a 100-byte
        big-endian XWD header, the window name, ``ncolors`` 12-byte colour entries, then the
        pixels, 32 bits each (blue, green, red, pad in LSB-first byte order) at depth 24.
        Raises RuntimeError without ``fbdir`` or for another pixel layout.
        """
        import struct

        import numpy as np

        if self.fbdir is None:
            raise RuntimeError("screenshot() needs VirtualDisplay(fbdir=...)")
        with open(os.path.join(self.fbdir, "Xvfb_screen0"), "rb") as f:
            raw = f.read()
        head = struct.unpack(">25I", raw[:100])
        size, width, height, byte_order, bpp, line, ncolors = (head[0], head[4], head[5], head[7],
                                                               head[11], head[12], head[19])
        if bpp != 32:
            raise RuntimeError(f"Xvfb screen of {bpp} bits per pixel: screenshot() reads 32 (depth 24)")
        pixels = np.frombuffer(raw, np.uint8, count=height * line, offset=size + 12 * ncolors)
        pixels = pixels.reshape(height, line)[:, :width * 4].reshape(height, width, 4)
        return np.ascontiguousarray(pixels[..., :3] if byte_order == 0 else pixels[..., 3:0:-1])

    def env(self, base: Optional[Mapping[str, str]] = None) -> dict:
        """Return a copy of ``base`` (default ``os.environ``) for a client of this display.

        Sets ``DISPLAY`` to :attr:`display` and ``SDL_VIDEODRIVER=x11`` (so
        SDL/pygame neither picks the dummy/offscreen driver nor Wayland), and
        removes ``WAYLAND_DISPLAY``.
        """
        env = dict(os.environ if base is None else base)
        env["DISPLAY"] = self.display
        env["SDL_VIDEODRIVER"] = "x11"
        env.pop("WAYLAND_DISPLAY", None)
        return env

    def close(self) -> None:
        """Terminate the Xvfb process this object started (SIGTERM, then SIGKILL after 5 s).

        Idempotent; never signals any other process.
        """
        proc, self._proc = getattr(self, "_proc", None), None
        if proc is not None:
            if proc.poll() is None:
                proc.terminate()  # signals proc.pid only
                try:
                    proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait(timeout=5)
        err, self._stderr = getattr(self, "_stderr", None), None
        if err is not None:
            try:
                err.close()
            except OSError:
                pass

    def __enter__(self) -> "VirtualDisplay":
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass

    def __repr__(self) -> str:
        state = "running" if getattr(self, "_proc", None) is not None else "closed"
        return f"<VirtualDisplay {self.display or '?'} pid={self.pid} {state}>"


def _high_priority() -> None:
    """In the xdotool child before it runs: a higher scheduling priority where allowed (root),
    so that on a loaded machine it is not preempted between a key's press and its release (a
    program that pumps its events once per slow frame then sees the key held, and repeats it)."""
    try:
        os.nice(-10)
    except OSError:
        pass


def _xdotool(display: str, *args: str, timeout: float = _XDOTOOL_CALL_TIMEOUT_S,
             check: bool = True) -> subprocess.CompletedProcess:
    """Run ``xdotool ARGS`` against ``display``; RuntimeError on failure/timeout."""
    exe = shutil.which("xdotool")
    if exe is None:
        raise RuntimeError(f"xdotool not found on PATH; {FIX_HINT}")
    env = dict(os.environ)
    env["DISPLAY"] = display
    try:
        res = subprocess.run([exe, *args], env=env, stdin=subprocess.DEVNULL,
                             capture_output=True, text=True, timeout=timeout, preexec_fn=_high_priority)
    except subprocess.TimeoutExpired as exc:
        raise RuntimeError(
            f"`xdotool {' '.join(args)}` on {display} timed out after {timeout:.1f} s") from exc
    if check and res.returncode != 0:
        raise RuntimeError(
            f"`xdotool {' '.join(args)}` on {display} failed (exit {res.returncode}): "
            f"{res.stderr.strip()}")
    return res


def _window_title(display: str, window_id: str) -> Optional[str]:
    """Title of ``window_id`` via ``xdotool getwindowname``; None if it has gone."""
    res = _xdotool(display, "getwindowname", window_id, check=False)
    return res.stdout.rstrip("\n") if res.returncode == 0 else None


def find_window(display: str, name: str, timeout: float = 20.0) -> str:
    """Wait for a mapped (viewable) window whose title matches ``name``; return its id.

    ``name`` is a Python regular expression, matched with :func:`re.search`
    against each visible window's title as ``xdotool getwindowname`` reports
    it (so ``"probe"`` matches the title ``"xdisplay probe"``; use
    ``re.escape``/anchors for an exact title).  The title is matched here
    rather than with ``xdotool search --name`` because xdotool 3.20160805
    (Debian 12, Ubuntu 22.04) does not match UTF8_STRING ``WM_NAME``
    properties, which is how SDL2/pygame sets titles.

    Polls every 50 ms until ``timeout`` seconds have passed; each xdotool
    call has its own subprocess timeout, so this never hangs.  Returns the
    window id as a decimal string (as xdotool prints it); when several
    windows match, the first one listed.

    Raises:
        RuntimeError: xdotool is missing, or no such window appeared in time
            (message includes the titles seen and xdotool's last stderr,
            e.g. "Can't open display").
    """
    pattern = re.compile(name)
    deadline = time.monotonic() + timeout
    last_stderr = ""
    seen: dict = {}
    while True:
        left = deadline - time.monotonic()
        # No --name/--class flag: matches windows with any name, class or classname.
        res = _xdotool(display, "search", "--onlyvisible", ".",
                       timeout=max(1.0, min(_XDOTOOL_CALL_TIMEOUT_S, left)), check=False)
        if res.stderr.strip():
            last_stderr = res.stderr.strip()
        for wid in res.stdout.split():
            title = _window_title(display, wid)
            if title is None:
                continue
            seen[wid] = title
            if pattern.search(title):
                return wid
        if time.monotonic() >= deadline:
            raise RuntimeError(
                f"no visible window with a title matching /{name}/ on {display} within "
                f"{timeout:.1f} s; visible titles: {sorted(set(seen.values()))}"
                + (f"; xdotool stderr: {last_stderr}" if last_stderr else ""))
        time.sleep(0.05)


def send_keys(display: str, window_id: str, *keys: str, delay_ms: int = 50) -> None:
    """Focus ``window_id`` and type ``keys`` into it as real X key events.

    Focus uses ``xdotool windowfocus --sync`` (XSetInputFocus, which works
    without a window manager, unlike ``windowactivate``).  The keys are then
    sent with ``xdotool key`` *without* ``--window``, i.e. through the XTEST
    extension, so they arrive as genuine KeyPress/KeyRelease events that
    SDL2/pygame reports as KEYDOWN/KEYUP (``--window`` would use
    XSendEvent, which many toolkits ignore).

    Args:
        display: X display name, e.g. ``":99"``.
        window_id: id returned by :func:`find_window`.
        keys: xdotool keysym names, e.g. ``"q"``, ``"space"``, ``"Return"``,
            ``"ctrl+c"``; each is pressed and released in turn.
        delay_ms: pause between successive keystrokes, milliseconds.

    Raises:
        RuntimeError: xdotool is missing, the window cannot be focused (e.g. it
            is gone or unmapped), or a call does not finish within 10 s.
    """
    if not keys:
        return
    _xdotool(display, "windowfocus", "--sync", str(window_id))
    _xdotool(display, "key", "--delay", str(int(delay_ms)), *keys,
             timeout=_XDOTOOL_CALL_TIMEOUT_S + len(keys) * delay_ms / 1000.0)
