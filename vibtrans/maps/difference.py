"""The difference of two drift maps (mu 0.1 against 0.3, the two models,
preview against standard, a computed map against a shipped one).

The second map is read at the first's grid points (its nearest point within
half a step; points either map lacks are not compared).  Per point: both
drifts, their difference in the signed log scale s(v) = sign(v) log10(1 +
|v|/v0) (decades, continuous through zero), and whether the drift class
differs.  The attributes summarize the points regular in both: the share
whose class agrees and the median of |v2 - v1| / max(|v1|, v0).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from vibtrans.analysis.summary import V0
from vibtrans.core.errors import InputError

GRID = ("log_amplitude", "log_mass")


def signed_log(v: Any, v0: float = V0) -> Any:
    """s(v) = sign(v) log10(1 + |v| / v0): decades of drift, 0 at v = 0."""
    v = np.asarray(v, dtype=float)
    return np.sign(v) * np.log10(1.0 + np.abs(v) / v0)


# (attribute, wording, the shipped maps' value): a map's name says what differs
# ("deformable mu 0.5 preview 500 periods")
DESCRIBED = (
    ("scene_theta", "theta {}", 1.2),
    ("scene_nu", "nu {}", 0.3),
    ("scene_tau", "tau {}", 50.0),
    ("scene_fidelity", "{}", "standard"),
    ("scene_periods", "{} periods", 2000.0),
    ("scene_profile", "{}", "sphere"),  # (a sphere's map names no profile)
    ("stop", "stop {}", "full"),
)  # (a full map's store names no rule)


def describe(ds: xr.Dataset) -> str:
    """A map's short name: model and mu, then what differs from the shipped maps."""
    a = ds.attrs
    parts = [str(a.get("scene_model", "?")), f"mu {a.get('scene_mu', '?')}"]
    for key, fmt, usual in DESCRIBED:
        value = a.get(key, usual)
        if value != usual:
            parts.append(fmt.format(f"{value:g}" if isinstance(value, float) else value))
    return " ".join(parts)


def _finished(ds):
    """Points with data (finished, finite)."""
    done = np.ones((ds.sizes["log_amplitude"], ds.sizes["log_mass"]), dtype=bool)
    if "point_done" in ds:
        done &= ds["point_done"].values[:, None]
    return done & np.isfinite(ds["drift_velocity"].values)


def _step(coord):
    values = np.asarray(coord, dtype=float)
    return float(np.min(np.diff(values))) if values.size > 1 else np.inf


def map_difference(first: Any, second: Any, v0: float = V0) -> xr.Dataset:
    """`second` against `first` (drift maps) on first's grid: a Dataset of
    drift_velocity_first/_second, drift_first/_second, compared,
    class_changed, chaotic_either and log_difference (NaN where not
    compared); attrs name the maps and give compared_points, regular_points,
    class_agreement and median_relative_difference (NaN if none regular)."""
    if not (isinstance(v0, (int, float)) and not isinstance(v0, bool) and np.isfinite(v0) and v0 > 0):
        raise InputError(f"v0 must be a positive number, got {v0!r}")
    for name, ds in (("first", first), ("second", second)):
        missing = [v for v in ("drift_velocity", "drift", "chaotic", *GRID) if v not in ds]
        if missing:
            raise InputError(f"{name} map: not a drift map (missing {', '.join(missing)})")
    la, lm = first["log_amplitude"].values, first["log_mass"].values
    tolerance = 0.5 * min(_step(la), _step(lm))
    if not np.isfinite(tolerance):
        tolerance = 1e-9
    b = second.assign(finished=(GRID, _finished(second)))[["drift_velocity", "drift", "chaotic", "finished"]]
    b = b.sortby(list(GRID)).reindex(
        log_amplitude=la, log_mass=lm, method="nearest", tolerance=tolerance + 1e-9
    )
    compared = _finished(first) & (b["finished"].values == True)  # noqa: E712 (NaN: False)
    if not compared.any():
        raise InputError(
            f"the maps share no point: first covers log10 A* "
            f"[{la.min():g}, {la.max():g}], log10 m* [{lm.min():g}, {lm.max():g}]; "
            f"second log10 A* [{second['log_amplitude'].values.min():g}, "
            f"{second['log_amplitude'].values.max():g}], log10 m* "
            f"[{second['log_mass'].values.min():g}, "
            f"{second['log_mass'].values.max():g}]"
        )
    v1 = np.where(compared, first["drift_velocity"].values, np.nan)
    v2 = np.where(compared, b["drift_velocity"].values, np.nan)
    d1 = first["drift"].values.astype(float)
    d2 = b["drift"].values.astype(float)
    chaotic = compared & ((first["chaotic"].values == 1) | (b["chaotic"].values == 1))
    changed = compared & (d1 != d2)
    regular = compared & ~chaotic
    agreement = float((~changed[regular]).mean()) if regular.any() else float("nan")
    relative = np.abs(v2 - v1) / np.maximum(np.abs(v1), v0)
    median = float(np.median(relative[regular])) if regular.any() else float("nan")
    data = dict(
        drift_velocity_first=v1,
        drift_velocity_second=v2,
        drift_first=np.where(compared, d1, np.nan),
        drift_second=np.where(compared, d2, np.nan),
        compared=compared,
        class_changed=changed,
        chaotic_either=chaotic,
    )
    data = {k: (GRID, v) for k, v in data.items()}
    s = np.where(compared, signed_log(v2, v0) - signed_log(v1, v0), np.nan)
    data["log_difference"] = (GRID, s, {"description": "s(v2) - s(v1), s(v) = sign(v) log10(1 + |v|/v0)"})
    attrs = dict(
        first=describe(first),
        second=describe(second),
        v0=float(v0),
        compared_points=int(compared.sum()),
        regular_points=int(regular.sum()),
        class_agreement=agreement,
        median_relative_difference=median,
    )
    return xr.Dataset(data, coords={"log_amplitude": la, "log_mass": lm}, attrs=attrs)
