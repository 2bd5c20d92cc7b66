"""Text of a peer's values in messages: :func:`quote` cuts a value's repr to a bounded length,
:func:`zenoh_reason` removes the Rust source locations from a Zenoh error.
"""

from __future__ import annotations

import re
import reprlib
from typing import Any

QUOTE_LIMIT = 60  # characters of a peer's value quoted in an error or a log line


#: The Rust source location Zenoh appends to its errors (`` at /root/.cargo/.../tcp.rs:61.``).
_SOURCE_LOCATION = re.compile(r"\s+at /\S+?\.rs:\d+\.?")


def zenoh_reason(error: BaseException | str) -> str:
    """A Zenoh error's text without the library's source locations, which tell a user nothing."""
    return _SOURCE_LOCATION.sub("", str(error)).strip()


def quote(value: Any, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` cut to ``limit`` characters (with ``...`` and the full length), for error
    messages and log lines that name a peer's input, on both sides: an attacker's 10 MB name must
    not come back as a 10 MB reply, and a value nested 1,000 deep must not overflow the stack."""
    r = reprlib.Repr()
    r.maxstring = r.maxother = limit
    r.maxlevel, r.maxlist, r.maxtuple, r.maxdict = 3, 8, 8, 8
    try:
        text = r.repr(value)
    except Exception:  # a value whose repr fails is named by its type
        text = f"<{type(value).__name__}>"
    if len(text) > limit:
        size = len(value) if isinstance(value, (str, bytes, list, dict)) else None
        text = text[:limit] + "..." + (f" ({size} long)" if size is not None else "")
    return text
