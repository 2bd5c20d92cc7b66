"""simx_server/base/arguments.py: the server's one vocabulary of argument checks."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from simx_server.base.arguments import (
    as_bytes,
    as_float,
    as_floats,
    as_int,
    as_integer,
    as_number,
    as_text,
    as_vector,
    check_args,
)
from simx_wire.protocol import ArgumentError


def test_wire_values_are_exact() -> None:
    assert check_args([1, 2, "a"], "int", "float", "str") == [1, 2.0, "a"]
    assert type(check_args([1, 2], "int", "float")[1]) is float
    cases: list[tuple[list[Any], list[str], str]] = [
        ([1.0], ["int"], "argument 1 must be an int"),
        ([True], ["int"], "must be an int"),
        (["x"], ["float"], "must be a number"),
        ([1], ["str"], "must be a string"),
        ([1, 2], ["int"], "expected 1 arguments, got 2"),
    ]
    for args, kinds, match in cases:
        with pytest.raises(ArgumentError, match=match):
            check_args(args, *kinds)
    assert as_int(3, "h") == 3 and as_float(2, "x") == 2.0
    with pytest.raises(ArgumentError, match="position must be finite"):
        as_floats([0, math.nan, 0], 3, "position")


def test_script_values_take_integral_floats_and_numpy() -> None:
    assert as_integer(3.0, "h") == 3 and type(as_integer(np.int32(7), "h")) is int
    assert as_number(np.float32(0.5), "x") == 0.5 and as_vector(np.zeros(3), 3, "p") == [0.0, 0.0, 0.0]
    calls: list[tuple[Callable[[], object], str]] = [
        (lambda: as_integer(2.5, "handle"), "handle must be an integer"),
        (lambda: as_integer(True, "handle"), "must be an integer"),
        (lambda: as_number(math.inf, "speed"), "speed must be finite"),
        (lambda: as_vector([1, 2], 3, "pos"), "pos must be a table of 3 numbers"),
        (lambda: as_vector([1, "a", 3], 3, "pos"), r"pos\[2\] must be a number"),
        (lambda: as_text(5, "name"), "name must be a string"),
    ]
    for call, match in calls:
        with pytest.raises(ArgumentError, match=match):
            call()
    assert as_text(b"caf\xc3\xa9", "name") == "café"


def test_bytes() -> None:
    assert as_bytes("é", "buf") == "é".encode() and as_bytes(memoryview(b"ab"), "buf") == b"ab"
    assert as_bytes([-1, 0, 255], "image", byte_values=True) == b"\xff\x00\xff"
    assert as_bytes([], "image", byte_values=True) == b""
    for value, kw, match in [
        ([1], {}, "buf must be a string"),
        ("ab", {"byte_values": True}, "must be bytes or a list"),
        ([256], {"byte_values": True}, "ints in -128..255"),
        ([0.5], {"byte_values": True}, "ints in -128..255"),
    ]:
        with pytest.raises(ArgumentError, match=match):
            as_bytes(value, "image" if kw else "buf", **kw)
