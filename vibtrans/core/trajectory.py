"""The result of a run: an xarray.Dataset of decimated samples and exact events.

    dims:  time (recorded instants), event (take-offs, landings, state changes)
    vars:  x, vx, y, vy, a, b, bdot, N, T, state, stick_radius, contact_radius
           event_time, event_kind, event_value; a rolling particle's also
           roll, roll_velocity, slip_velocity (docs/MODEL.md section 11)
    attrs: every scene parameter, r, the step h, steps, force_evaluations,
           seconds, the code version, and the run's window; a rolling
           particle's inertia_ratio j and max_episode_roll.

Normalized units (docs/MODEL.md): lengths in a0 (b* in theta mu a0), time in wave
periods, forces in N(a0) (T* in mu N(a0)).  state codes: contact.STATE_NAMES.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import STATE_NAMES

if TYPE_CHECKING:
    from typing import Any

_UNITS = {
    "x": ("x*", "horizontal position / a0"),
    "vx": ("x*'", "horizontal velocity, a0 per period"),
    "y": ("y*", "vertical position (down) / a0"),
    "vy": ("y*'", "vertical velocity, a0 per period"),
    "a": ("a*", "normal contact displacement / a0"),
    "b": ("b*", "tangential contact displacement / (theta mu a0)"),
    "bdot": ("b*'", "relative tangential velocity, theta mu a0 per period"),
    "N": ("N*", "normal force / N(a0)"),
    "T": ("T*", "tangential force / (mu N(a0))"),
    "stick_radius": ("s", "stick radius, units of sqrt(R a0)"),
    "contact_radius": ("c", "contact radius, units of sqrt(R a0)"),
    "roll": ("omega R dt", "rolled arc, the integral of omega R, / a0 (angle x R / a0)"),
    "roll_velocity": ("omega R", "rolling velocity of the surface about the centre, a0 per period"),
    "slip_velocity": (
        "x*' + omega R - u_x*'",
        "contact point's velocity relative to the substrate, a0 per period",
    ),
}


def _rolling_columns(columns, attrs):
    """A rolling particle's rotation, which the kernel does not record: with
    j (omega R)' = x*'' from rest, omega R = x*'/j and its integral x*/j at
    every instant (flights included); the contact point slips at
    theta mu b*' (b*' = ((1 + 1/j) x*' - u_x*') / (theta mu))."""
    roll_ratio = 1.0 / float(attrs["inertia_ratio"])  # as the kernel's (simulate.roll_ratio)
    columns["roll"] = columns["x"] * roll_ratio
    columns["roll_velocity"] = columns["vx"] * roll_ratio
    columns["slip_velocity"] = columns["bdot"] * (float(attrs["theta"]) * float(attrs["mu"]))


class _Column:
    __slots__ = ("values",)

    def __init__(self, values):
        self.values = values


class RunArrays:
    """A run's variables as `build_trajectory`'s Dataset holds them (the
    same arrays: `ds[name].values`, and `ds.attrs`), without building the
    Dataset: all that vibtrans.analysis.summary reads.  A map point (sweep.py) is
    summarized and dropped; at preview fidelity building its Dataset cost
    more than its kernel.  The float columns are views of the buffers'
    columns (a map point reads a few of them: copying all cost ~1 ms a
    point, a fifth of a decided material point's time); `contiguous=True`
    copies them (a Dataset to keep)."""

    __slots__ = ("columns", "attrs")

    def __init__(self, samples: Any, events: np.ndarray, attrs: Any, contiguous: bool = False) -> None:
        take = np.ascontiguousarray if contiguous else (lambda column: column)
        columns = {"time": take(samples[:, R.T_])}
        for i, name in enumerate(R.COLUMNS):
            if name not in ("t", "state"):
                columns[name] = take(samples[:, i])
        columns["state"] = samples[:, R.STATE].astype(np.int8)
        if "inertia_ratio" in attrs:
            _rolling_columns(columns, attrs)
        columns["event_time"] = take(events[:, 0])
        columns["event_kind"] = events[:, 1].astype(np.int8)
        columns["event_value"] = take(events[:, 2])
        self.columns = columns  # name -> array
        # what a Dataset can store: no None, booleans as 0/1
        self.attrs: dict[str, Any] = {
            k: (v if not isinstance(v, bool) else int(v)) for k, v in attrs.items() if v is not None
        }

    def __getitem__(self, name):
        return _Column(self.columns[name])


def build_trajectory(samples: Any, events: np.ndarray, attrs: Any) -> xr.Dataset:
    """Dataset from the kernel's trimmed sample and event buffers: the
    arrays of their RunArrays, with units and flag meanings."""
    run = RunArrays(samples, events, attrs, contiguous=True)
    data: dict[str, tuple] = {}
    for name, array in run.columns.items():
        if name in _UNITS:
            symbol, desc = _UNITS[name]
            data[name] = ("time", array, {"symbol": symbol, "long_name": desc})
    data["state"] = (
        "time",
        run.columns["state"],
        {
            "flag_values": list(range(len(STATE_NAMES))),
            "flag_meanings": " ".join(s.replace(" ", "_") for s in STATE_NAMES),
        },
    )
    data["event_time"] = ("event", run.columns["event_time"])
    data["event_kind"] = ("event", run.columns["event_kind"], {"flag_meanings": " ".join(R.EVENT_NAMES)})
    data["event_value"] = ("event", run.columns["event_value"])
    return xr.Dataset(
        data, coords={"time": ("time", run.columns["time"], {"units": "wave periods"})}, attrs=run.attrs
    )


def events_of(ds: xr.Dataset, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the events of one kind (records.TAKEOFF, ...)."""
    sel = ds["event_kind"].values == kind
    return ds["event_time"].values[sel], ds["event_value"].values[sel]
