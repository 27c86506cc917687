"""Launched runs and the one-line verdict on real scenes.

Sources: closed form (a flight is ballistic, m* y*'' = 1 and x*'' = 0,
docs/MODEL.md sections 1 and 3; the point mass leaves the surface where
N* = 1 - m* u_y*'' turns negative, with the surface's vertical velocity,
so under the unramped wave (tau = 0) its flight lasts about 4 pi A* m*
periods), the events of the runs, and the shipped maps (what a sweep
stores must not change).
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from vibtrans import paper_scene, simulate
from vibtrans.analysis import summary as an
from vibtrans.cli import main
from vibtrans.core.params import Scene
from vibtrans.maps.sweep import DRIFTS, PATTERNS, SCENE_KEYS, compute_point, open_map

MAPS = Path(__file__).resolve().parents[2] / "assets" / "maps"
# the upper right of both maps: log10 A* = 2.5, log10 m* = 3
UPPER_RIGHT = dict(amplitude=10.0**2.5, mass=10.0**3.0)


def run(scene):
    ds = simulate(scene)
    return ds, an.summarize(ds, simulate(an.twin_scene(scene)))


def assert_ballistic_after(ds, t0):
    """Every sample after t0 lies on the flight's parabola and line, which
    end at the run's last sample (the flight in progress is free fall)."""
    t, T = ds["time"].values, float(ds["time"].values[-1])
    m = float(ds.attrs["mass"])
    sel = t > t0 + 1.0
    s = t[sel] - T
    y_end, vy_end = float(ds["y"].values[-1]), float(ds["vy"].values[-1])
    scale = abs(y_end) + abs(vy_end) * T
    np.testing.assert_allclose(
        ds["y"].values[sel], y_end + vy_end * s + s * s / (2.0 * m), rtol=0, atol=1e-9 * scale
    )
    np.testing.assert_allclose(ds["vx"].values[sel], float(ds["vx"].values[-1]), rtol=1e-12)


@pytest.mark.parametrize("model, t_launch", [("point-mass", 17.45), ("deformable", 72.52)])
def test_the_upper_right_is_launched_not_a_transport_regime(model, t_launch):
    ds, s = run(Scene(model=model, **UPPER_RIGHT))
    T = float(ds["time"].values[-1])
    # hops a few times during the ramp (tau = 50), then one flight to the end
    starts, ends = an.flights(ds)
    assert math.isinf(ends[-1]) and np.isfinite(ends[:-1]).all()
    assert starts[-1] == pytest.approx(t_launch, abs=0.01) and starts[-1] < 3.0 * 50.0
    assert (s.launched, s.launch_time, s.pattern, s.model) == (True, starts[-1], "launched", model)
    assert s.contact_fraction == 0.0 and s.takeoffs_per_period == 0.0
    assert_ballistic_after(ds, starts[-1])
    # far from coming back: the ballistic landing lies beyond 8 runs' length
    assert s.earliest_landing > 8.0 * T
    # its "drift" is its flight velocity (-71 for the point mass)
    vx = float(ds["vx"].values[-1])
    assert s.final_drift_velocity == pytest.approx(vx, rel=1e-9)
    assert s.drift_velocity == pytest.approx(vx, rel=0.05)
    assert s.regime.startswith(f"launched: leaves the substrate at t* = {starts[-1]:.4g} ")
    assert "no transport regime" in s.regime
    assert not any(w in s.regime for w in ("irregular", "with the wave", "against the wave"))
    assert s.twin_steps > 0 and s.steps == int(ds.attrs["steps"])


def test_an_unramped_launch_flies_4_pi_A_m_periods():
    # tau = 0: N* = 1 + m* (2 pi)^2 A* cos(2 pi t) first turns negative at
    # cos(2 pi t) = -1/(4 pi^2 A* m*); the point leaves from y* = u_y* with
    # the surface's velocity -2 pi A* sin(2 pi t) and cannot come back within
    # reach (y* = -A*) before the root of the free-fall parabola.
    A, m = 1000.0, 1000.0
    ds, s = run(Scene(model="point-mass", tau=0.0, amplitude=A, mass=m))
    phase = math.acos(-1.0 / (4.0 * math.pi**2 * A * m)) / (2.0 * math.pi)
    y0 = A * math.cos(2.0 * math.pi * phase)
    v_up = 2.0 * math.pi * A * math.sin(2.0 * math.pi * phase)
    flight = m * (v_up + math.sqrt(v_up**2 - 2.0 * (y0 + A) / m))  # y0 - v_up s + s^2/(2 m) = -A
    assert s.launched and s.launch_time == pytest.approx(phase, abs=1e-9)
    assert s.earliest_landing == pytest.approx(phase + flight, rel=1e-9)
    assert s.earliest_landing == pytest.approx(4.0 * math.pi * A * m, rel=1e-6)
    assert s.drift == "with-wave" and "with the wave" not in s.regime


@pytest.mark.parametrize("point, pattern", [(4, "synchronous"), (5, "multi-synchronous")])
def test_hopping_runs_that_end_mid_flight_are_not_launched(point, pattern):
    ds, s = run(paper_scene(point))
    starts, ends = an.flights(ds)
    assert math.isinf(ends[-1])  # both end in the middle of a flight
    assert (s.launched, s.launch_time, s.earliest_landing) == (False, None, None)
    assert s.pattern == pattern and s.chaotic is False
    assert s.regime == f"jumping, {pattern}, drift against the wave (-x)"


def test_bursts_whose_long_flight_spans_the_final_window_are_not_launched():
    # log10 A* = 2.5, log10 m* = 1.55 (beside paper point 5): the run ends in
    # a flight begun before the final window, as long as its earlier ones
    ds, s = run(Scene(amplitude=10.0**2.5, mass=10.0**1.55))
    T = float(ds["time"].values[-1])
    starts, ends = an.flights(ds)
    assert math.isinf(ends[-1]) and starts[-1] < (1.0 - an.FINAL_FRACTION) * T
    done = ends[:-1] - starts[:-1]
    longest = done[starts[:-1] > 3.0 * 50.0].max()
    assert 300.0 < longest and an.earliest_landing(ds) - starts[-1] < 1.1 * longest
    assert not s.launched and s.pattern == "multi-synchronous"
    assert s.regime == "jumping, multi-synchronous, drift against the wave (-x)"


def test_a_sweep_stores_what_the_shipped_maps_hold_for_launched_points():
    # the maps were computed before launched runs had a name: a sweep still
    # stores their take-off pattern, and run + twin costs
    for model in ("point-mass", "deformable"):
        ds = open_map(str(MAPS / f"{model}-mu0.3.zarr"))
        values = {k: ds.attrs[f"scene_{k}"] for k in SCENE_KEYS if f"scene_{k}" in ds.attrs}
        i = int(np.argmin(np.abs(ds["log_amplitude"].values - 2.5)))
        j = int(np.argmin(np.abs(ds["log_mass"].values - 3.0)))
        got = compute_point(values, float(ds["log_amplitude"][i]), float(ds["log_mass"][j]))
        for name in (
            "drift_velocity",
            "final_drift_velocity",
            "contact",
            "drift",
            "pattern",
            "chaotic",
            "contact_fraction",
            "takeoffs_per_period",
            "steps",
        ):
            assert got[name] == pytest.approx(float(ds[name].values[i, j]), rel=1e-9), name
        assert PATTERNS[got["pattern"]] == "irregular" and got["drift"] == DRIFTS["against-wave"]
        scene = Scene(amplitude=10.0**2.5, mass=10.0**3.0, **values)
        s = an.summarize(simulate(scene), simulate(an.twin_scene(scene)))
        assert s.launched and got["steps"] == s.steps + s.twin_steps


SHORT_LAUNCH = [
    "simulate",
    "--model",
    "point-mass",
    "--tau",
    "0",
    "--amplitude",
    "1000",
    "--mass",
    "1000",
    "--periods",
    "20",
]


def test_cli_prints_the_verdict_and_the_twin_cost_apart(capsys):
    assert main([*SHORT_LAUNCH, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(an.Summary._fields) <= set(out)
    assert out["model"] == "point-mass" and out["launched"] is True
    assert out["regime"].startswith("launched: ") and out["pattern"] == "launched"
    assert out["steps"] > 0 and out["twin_steps"] > 0 and out["twin_seconds"] >= 0.0
    assert main(SHORT_LAUNCH) == 0
    lines = {
        line.split(":", 1)[0].strip(): line.split(":", 1)[1].strip()
        for line in capsys.readouterr().out.splitlines()
    }
    assert lines["regime"].startswith("launched: leaves the substrate")
    assert int(lines["twin_steps"]) == out["twin_steps"] and int(lines["steps"]) == out["steps"]
    assert main([*SHORT_LAUNCH, "--twin", "never", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["chaotic"], out["twin_steps"], out["twin_seconds"]) == (None, 0, 0.0)
