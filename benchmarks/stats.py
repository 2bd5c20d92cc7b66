"""Summaries and the result record every benchmark returns."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Iterable

import numpy as np


def summary(values: Iterable[float]) -> dict[str, float]:
    """Median, p10, p90, min, max, mean and count of a sample (NaNs when empty)."""
    a = np.asarray(list(values), dtype=float)
    if a.size == 0:
        nan = float("nan")
        return {"median": nan, "p10": nan, "p90": nan, "min": nan, "max": nan, "mean": nan, "n": 0}
    p10, p50, p90 = np.percentile(a, [10, 50, 90])
    return {"median": float(p50), "p10": float(p10), "p90": float(p90), "min": float(a.min()),
            "max": float(a.max()), "mean": float(a.mean()), "n": int(a.size)}


def rate_summary(intervals_s: Iterable[float]) -> dict[str, float]:
    """Events per second from inter-event intervals: median = 1/median interval; the slow end
    (p10) comes from the p90 interval and vice versa."""
    s = summary(intervals_s)
    inv = lambda x: 1.0 / x if x and x > 0 and math.isfinite(x) else float("nan")  # noqa: E731
    return {"median": inv(s["median"]), "p10": inv(s["p90"]), "p90": inv(s["p10"]),
            "min": inv(s["max"]), "max": inv(s["min"]), "mean": inv(s["mean"]), "n": s["n"]}


def scaled(s: dict[str, float], k: float) -> dict[str, float]:
    """A summary with every value statistic multiplied by ``k`` (units, e.g. s -> ms)."""
    return {key: (v * k if key != "n" else v) for key, v in s.items()}


@dataclasses.dataclass
class Target:
    """A goal on a figure: ``on`` is "ratio" (median / floor median) or "value" (median)."""

    on: str
    op: str  # "<=", ">=", "<", ">", "=="
    bound: float
    text: str = ""

    def check(self, value: float | None) -> bool | None:
        if value is None or not math.isfinite(value):
            return None
        return {"<=": value <= self.bound, ">=": value >= self.bound, "<": value < self.bound,
                ">": value > self.bound, "==": value == self.bound}[self.op]

    def describe(self) -> str:
        return self.text or f"{self.on} {self.op} {self.bound:g}"


@dataclasses.dataclass
class Figure:
    """One row of the results table."""

    key: str
    label: str
    unit: str
    stats: dict[str, float]
    floor: dict[str, Any] | None = None  # {"label": ..., "median": ..., "p10": ..., "p90": ...}
    target: Target | None = None
    note: str = ""
    extra: dict[str, Any] = dataclasses.field(default_factory=dict)
    ratio: float | None = None
    met: bool | None = None
    #: Skipped because something optional is not on this machine (a package, Xvfb, the tutorial's
    #: files, a port another program holds), which the note names: not an error (``--smoke``
    #: fails on any other skip).
    unavailable: bool = False

    def __post_init__(self) -> None:
        if self.floor is not None and self.floor.get("median"):
            self.ratio = self.stats["median"] / self.floor["median"]
        if self.target is not None:
            value = self.ratio if self.target.on == "ratio" else self.stats["median"]
            self.met = self.target.check(value)

    def as_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["target"] = None if self.target is None else {**dataclasses.asdict(self.target),
                                                        "text": self.target.describe()}
        return d


def skipped(key: str, label: str, why: str) -> Figure:
    """A row for a figure that could not be measured in this run: an error (``--smoke`` fails)."""
    return Figure(key, label, "", summary([]), note=f"SKIPPED: {why}")


def unavailable(key: str, label: str, what: str) -> Figure:
    """A row for a figure this machine cannot measure: ``what`` optional is missing (a package, a
    program, a file); said in the table, not an error."""
    return Figure(key, label, "", summary([]), note=f"SKIPPED (not available here): {what}", unavailable=True)
