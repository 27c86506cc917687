"""The map's images as each page gets them (app/views/map.py `_as_sent`):
float32 where that changes no value a hover shows, float64 where it would.
The reference is HoloViews' own rendering of the same map element (float64
throughout), made here beside the explorer's cached one."""

import holoviews as hv
import numpy as np
import pytest
from bokeh.models import ColumnDataSource, HoverTool

from vibtrans_explorer.server import data
from vibtrans_explorer.views import map as M
from vibtrans_explorer.views.render import rendered

hv.extension("bokeh")  # as the explorer does


def _images(fig):
    """{(renderer index, column): [2-D arrays]} of a map figure's image
    columns."""
    out = {}
    for i, r in enumerate(fig.renderers):
        src = getattr(r, "data_source", None)
        if not isinstance(src, ColumnDataSource):
            continue
        for k, v in src.data.items():
            if isinstance(v, list) and v and all(isinstance(a, np.ndarray) and a.ndim == 2 for a in v):
                out[(i, k)] = v
    return out


def _hovered(fig):
    return {f.strip("@{}") for h in fig.select(type=HoverTool) for _, f in h.tooltips if f.startswith("@")}


@pytest.mark.parametrize("layer", [M.DRIFT_LAYER, M.LYAPUNOV_LAYER])
def test_hovered_values_exact_and_colours_float32(layer):
    if ("deformable", 0.3) not in data.available_maps():
        pytest.fail("the shipped maps are missing (assets/maps)")
    args = ("deformable", 0.3, 0.1, "grey", layer, M.NO_ORBITS)
    sent = M.map_figure(*args)
    _, reference = rendered(M.map_element, *args)
    got, ref = _images(sent), _images(reference)
    assert got.keys() == ref.keys() and got
    hovered = _hovered(sent)
    assert hovered  # the map's hover reads its columns
    light = 0
    for key, arrays in got.items():
        for a, b in zip(arrays, ref[key], strict=True):
            assert b.dtype == np.float64
            if key[1] in hovered:
                # what the hover shows: the very values
                assert np.array_equal(a.astype(np.float64), b, equal_nan=True), key
            else:
                # colour only: float32's rounding
                assert a.dtype == np.float32, key
                assert np.array_equal(np.isnan(a), np.isnan(b)), key
                assert np.allclose(a, b, rtol=1e-6, atol=1e-7, equal_nan=True), key
            light += a.dtype == np.float32
    assert light >= 1  # fewer bytes per page: some image sent as float32
