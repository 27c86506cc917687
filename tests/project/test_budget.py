"""The time budgets of the tests (tests/budget.py) scale with the machine's load."""

import budget as B
import pytest


def test_a_budget_is_never_below_the_idle_machine_one():
    assert B.factor() >= 1.0
    assert B.budget(10) >= 10
    assert B.budget_ms(10) == pytest.approx(B.budget(10) * 1000, rel=0.5)


def test_a_busy_machine_gets_a_longer_budget(monkeypatch):
    cores = B.usable_cores()
    monkeypatch.setattr(B.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert B.factor() == 1.0
    monkeypatch.setattr(B.os, "getloadavg", lambda: (3.0 * cores, 0.0, 0.0))
    assert B.factor() == pytest.approx((3.0 * cores + 1) / cores)
    assert B.budget(60) == pytest.approx(60 * (3.0 * cores + 1) / cores)


def test_the_environment_factor_multiplies_and_is_checked(monkeypatch):
    monkeypatch.setattr(B.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    monkeypatch.setenv("VIBTRANS_TEST_BUDGET_FACTOR", "2.5")
    assert B.budget(10) == pytest.approx(25.0)
    for bad in ("0.5", "fast"):
        monkeypatch.setenv("VIBTRANS_TEST_BUDGET_FACTOR", bad)
        with pytest.raises(ValueError, match="VIBTRANS_TEST_BUDGET_FACTOR"):
            B.factor()
