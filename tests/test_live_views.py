"""The explorer's live trajectory panels (app/live.py): a panel's second
quantity on an axis of its own, and the whole run as per-bin envelopes
(issue 14: N* and T* lay flat beside b*' in the thousands, b* and x* over
the last two periods were two flat lines, the whole-run panels were solid
bands)."""
import numpy as np
import pytest

from vibtrans import paper_scene, simulate
from vibtrans.plots import binned
from vibtrans_explorer.live import LiveTrajectory, right_columns


def test_binned_is_the_naive_per_bin_min_mean_max():
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0.0, 10.0, 500))
    v = rng.normal(size=500)
    v[[3, 77]] = np.nan
    out = binned(t, {"v": v}, 7)
    edges = np.linspace(t[0], t[-1], 8)
    k = 0
    for i in range(7):
        sel = (t >= edges[i]) & ((t < edges[i + 1]) if i < 6 else (t <= edges[i + 1]))
        if not sel.any():
            continue
        w = v[sel][np.isfinite(v[sel])]
        assert out["v_lo"][k] == w.min() and out["v_hi"][k] == w.max()
        assert out["v"][k] == pytest.approx(w.mean(), rel=1e-12)
        k += 1
    assert k == out["time"].size


@pytest.mark.parametrize("columns, right", [
    (["a", "y"], ["y"]), (["b", "x"], ["x"]), (["N", "T", "bdot"], ["bdot"]),
    (["y"], []), (["x"], []), (["N", "T"], [])])
def test_second_quantities_go_right(columns, right):
    assert right_columns(columns) == right


def test_forces_and_velocity_each_fill_their_axis():
    ds = simulate(paper_scene(4).replace(periods=40.0), window=(38.0, 40.0))
    view = LiveTrajectory(False, None, 2.0, 50.0)
    view.show(ds)
    for block, data in ((view.over, ds), (view.last, ds.isel(time=slice(-200, None)))):
        forces = next(f for f in block.figures if f.title.text.startswith("forces"))
        n_t = np.concatenate([ds["N"].values, ds["T"].values])
        bdot = ds["bdot"].values
        assert abs(bdot).max() > 10 * abs(n_t).max()       # the scales the issue met
        left, right = forces.y_range, forces.extra_y_ranges["right"]
        # each axis spans its own quantities, not the other's
        assert right.end - right.start > 10 * (left.end - left.start)
    # the whole run: per-bin bands, not every sample
    assert len(view.over.source.data["time"]) <= 400
    assert {"N_lo", "N_hi", "bdot_lo", "bdot_hi"} <= set(view.over.source.data)
