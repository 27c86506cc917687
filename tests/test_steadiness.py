"""A drift that is not steady is said so.  Paper
point 4 at 2000 periods drifts at -299 on average but at -569 over its last
tenth: still accelerating, so its mean depends on the run's length.  The
summary (`analysis.steadiness`, Summary.steady), `simulate --json`
(`steady`), the app's summary and the run's CSV export say it."""
import contextlib
import io
import json

import numpy as np
import pytest
import xarray as xr

from vibtrans.analysis import summary as analysis
from vibtrans.cli import main
from vibtrans.core.params import PAPER_POINTS


def _run(x_of_t, periods=2000.0, n=4001):
    t = np.linspace(0.0, periods, n)
    return xr.Dataset({"x": ("time", x_of_t(t))}, coords={"time": t})


def test_a_uniform_drift_is_steady_and_a_uniform_acceleration_is_not():
    # closed forms: x = v t has the same velocity over every window;
    # x = a t^2 / 2 has velocity a t, 0.8 a T then 0.9 a T over the last tenths
    steady, words = analysis.steadiness(_run(lambda t: -3.0 * t))
    assert steady and words.startswith("steady")
    a = -1e-3
    steady, words = analysis.steadiness(_run(lambda t: a * t ** 2 / 2))
    assert not steady
    assert words.startswith("not steady: still accelerating")
    assert "the mean depends on the run's length" in words
    assert f"{a * 0.85 * 2000:.4g}" in words and f"{a * 0.95 * 2000:.4g}" in words
    # a slowing run: velocity -4 + 1.5e-3 t, -1.45 then -1.15 over the last tenths
    steady, words = analysis.steadiness(_run(lambda t: -4.0 * t + 1.5e-3 * t ** 2 / 2))
    assert not steady and "still decelerating" in words
    # inside the no-drift band: steady whatever its relative change
    steady, _ = analysis.steadiness(_run(lambda t: 1e-6 * t ** 2))
    assert steady


@pytest.mark.slow
def test_point_4_says_it_is_still_accelerating():
    la, lm, model = PAPER_POINTS[4]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        main(["simulate", "--amplitude", str(10 ** la), "--mass", str(10 ** lm), "--model",
              model, "--json"])
    got = json.loads(out.getvalue())
    assert got["steady"] is False, got
    assert got["steadiness"].startswith("not steady: still accelerating"), got["steadiness"]
    # paper point 4's figures: the mean and the last tenth far apart
    assert abs(got["final_drift_velocity"]) > 1.5 * abs(got["drift_velocity"])
