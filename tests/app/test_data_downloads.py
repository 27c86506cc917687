"""The explorer's data downloads (for a lab): the run's samples
and events as netCDF and its samples as CSV, equal to the run shown; the
map's points inside the map's current (zoomed) view as netCDF, equal to the
shipped map there."""

import asyncio
import io

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from asyncutil import until

from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import data

pytestmark = pytest.mark.slow  # a real run in an explorer session


@pytest.fixture(scope="module")
def shown():
    async def go():
        ex = E.Explorer()
        ex.state.param.update(fidelity="preview", compare="none", log_amplitude=2.5, log_mass=0.0)
        ex.start_run()
        await until(lambda: ex.controller.job is None and "drift <v*>" in ex.summary_view.pane.object)
        return ex

    return asyncio.run(go())


def test_run_netcdf_is_the_run_shown(shown, tmp_path):
    ds = shown.controller.result.ds
    path = tmp_path / "run.nc"
    path.write_bytes(shown.exports.data_file("run", "nc").getvalue())
    with xr.open_dataset(path) as got:
        for name in ("x", "y", "a", "b", "N", "T", "state", "event_time", "event_kind"):
            assert np.array_equal(got[name].values, ds[name].values), name
        assert got.attrs["amplitude"] == ds.attrs["amplitude"]


def test_run_csv_is_the_run_shown(shown):
    ds = shown.controller.result.ds
    text = shown.exports.data_file("run", "csv").getvalue().decode()
    assert text.startswith("# vibtrans run: model=deformable")
    table = pd.read_csv(io.StringIO(text), comment="#")
    assert list(table["time"]) == list(ds["time"].values)  # %.17g: exact
    for name in ("x", "vx", "y", "a", "b", "bdot", "N", "T", "state"):
        assert np.array_equal(table[name].values, ds[name].values), name


def test_map_window_is_the_zoomed_view(shown, tmp_path):
    fig = shown.map_view.figures[0]
    fig.x_range.start, fig.x_range.end = 0.02, 1.3  # a zoom, off the grid
    fig.y_range.start, fig.y_range.end = -2.1, -0.4
    path = tmp_path / "map.nc"
    path.write_bytes(shown.exports.data_file("map-window", "nc").getvalue())
    full = data.drift_map("deformable", 0.3)
    la, lm = full["log_amplitude"].values, full["log_mass"].values
    inside_a = la[(la >= 0.02) & (la <= 1.3)]
    inside_m = lm[(lm >= -2.1) & (lm <= -0.4)]
    with xr.open_dataset(path) as got:
        assert np.array_equal(got["log_amplitude"].values, inside_a)
        assert np.array_equal(got["log_mass"].values, inside_m)
        want = full["drift_velocity"].sel(log_amplitude=inside_a, log_mass=inside_m)
        assert np.array_equal(got["drift_velocity"].values, want.values, equal_nan=True)


def test_each_download_is_named_after_what_it_holds(shown):
    # the run's scene and the map's model and mu are in the names: a second
    # download of another scene does not overwrite the first
    shown.exports.build()
    buttons = dict(
        zip(
            [
                "map.png",
                "map.svg",
                "map.html",
                "trajectory.png",
                "trajectory.svg",
                "trajectory.html",
                "run.nc",
                "run.csv",
                "map-window.nc",
            ],
            shown.exports.buttons,
        )
    )
    run = buttons["run.nc"]
    run.callback()
    assert run.filename == "vibtrans-run-deformable-A316.2-m1-mu0.3.nc"
    figure = buttons["map.png"]
    figure.callback()
    assert figure.filename == "vibtrans-map-deformable-mu0.3.png"
    window = buttons["map-window.nc"]
    window.callback()
    assert window.filename.startswith("vibtrans-map-window-deformable-mu0.3-la")


def test_download_names_differ_between_scenes():
    from vibtrans_explorer.views.exports import download_name

    a = {"model": "deformable", "amplitude": 0.5012, "mass": 10.0, "mu": 0.3, "profile": "sphere"}
    b = {**a, "profile": "power:3"}
    names = {download_name("run", "csv", scene=s) for s in (a, b, {**a, "mu": 0.1})}
    assert len(names) == 3
    assert download_name("run", "csv", scene=b) == "vibtrans-run-deformable-A0.5012-m10-mu0.3-power3.csv"
