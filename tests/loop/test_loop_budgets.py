"""The loop's budgets (simx_server/loop/budgets.py): a client's share of the simulation thread,
which both front doors charge scene loads and edits to, and the cut of long error messages."""

from __future__ import annotations

import pytest

from simx_server.base import limits
from simx_server.loop.budgets import Share, cut


@pytest.fixture
def share_limits(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(limits, "EDIT_SHARE", 0.25)  # the debt falls by 0.25 s per s
    monkeypatch.setattr(limits, "EDIT_DEBT_SECONDS", 1.0)


@pytest.mark.usefixtures("share_limits")
def test_a_share_is_over_past_its_debt_and_recovers_at_the_edit_share() -> None:
    share = Share(now=100.0)
    assert not share.over(100.0) and share.wait(100.0) == 0.0
    share.add(3.0, now=103.0)  # an edit of 3 s, done at 103 s: nothing paid while it ran
    assert share.debt == 3.0 and share.over(103.0)
    assert share.wait(103.0) == pytest.approx((3.0 - 1.0) / 0.25)  # 8 s until 1 s is owed
    assert share.owed(107.0) == pytest.approx(2.0) and share.over(107.0)
    assert not share.over(111.0) and share.wait(111.0) == 0.0
    assert share.owed(200.0) == 0.0  # never below nothing


@pytest.mark.usefixtures("share_limits")
def test_charge_pays_what_fell_due_first() -> None:
    share = Share(now=0.0)
    share.add(2.0, now=0.0)
    share.charge(0.5, now=4.0)  # 2 - 4 * 0.25 = 1, then + 0.5
    assert share.debt == pytest.approx(1.5) and share.since == 4.0


def test_cut_keeps_an_error_within_the_limit_and_says_how_long_it_was() -> None:
    long = "x" * 100_000
    assert len(cut(long)) == limits.MAX_ERROR_CHARS and cut(long).endswith("... (100000 characters)")
    assert cut("short") == "short"
    assert len(cut("y" * 300, 200)) == 200 and cut("y" * 300, 200).startswith("y" * 150)
