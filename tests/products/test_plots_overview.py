"""The whole-run view's data: the thinned full-resolution window and the
dominant state per time bin (vectorised; checked against the plain loop)."""

import numpy as np
import pytest

from vibtrans import Scene, simulate
from vibtrans.core.kernels.contact import STATE_NAMES
from vibtrans.products import plots


@pytest.fixture(scope="module")
def hopping():
    # paper point 6 region: long contact + jumps, many state changes
    return simulate(
        Scene(amplitude=10**0.22, mass=10**0.33, periods=200.0), window=(150.0, 200.0), samples_per_period=5
    )


def _dominant_loop(ds, bins):
    """The reference: bin by bin, run by run."""
    t0, t1, vals = plots._state_runs(ds)
    edges = np.linspace(t0[0], t1[-1], bins + 1)
    share = np.zeros((bins, len(STATE_NAMES)))
    for a, b, v in zip(t0, t1, vals):
        for k in range(bins):
            share[k, v] += max(0.0, min(b, edges[k + 1]) - max(a, edges[k]))
    dom = share.argmax(axis=1)
    cut = np.flatnonzero(np.diff(dom)) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [bins]])
    return edges[starts], edges[ends], dom[starts]


@pytest.mark.parametrize("bins", [1, 7, 400, pytest.param(5000, marks=pytest.mark.slow)])
def test_dominant_states_match_the_loop(hopping, bins):
    got = plots._dominant_states(hopping, bins)
    want = _dominant_loop(hopping, bins)
    assert len(got[2]) > (1 if bins >= 400 else 0)
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-9)


def test_overview_thins_only_the_window(hopping):
    t = hopping["time"].values
    w0, w1 = hopping.attrs["window_start"], hopping.attrs["window_end"]
    inside = (t > w0) & (t < w1)
    assert inside.sum() > 1000
    over = plots.overview_samples(hopping, window_samples=200)
    to = over["time"].values
    # outside the window every sample is kept; inside about 200; ends kept
    np.testing.assert_array_equal(to[(to <= w0) | (to >= w1)], t[~inside])
    assert 150 <= ((to > w0) & (to < w1)).sum() <= 202
    assert to[0] == t[0] and to[-1] == t[-1] and np.all(np.diff(to) > 0)
    assert over.sizes["event"] == hopping.sizes["event"]
    # a run without a window, or with a small one, is returned as it is
    assert plots.overview_samples(hopping, window_samples=10**9) is hopping
    plain = simulate(Scene(amplitude=1.0, mass=1.0, periods=20.0), samples_per_period=5)
    assert plots.overview_samples(plain) is plain


def _polygon_area(x, y):
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def test_binned_envelope_holds_every_sample(hopping):
    # the whole run is drawn as per-bin mean and min-max band: every sample
    # must lie inside its bin's band, each band's ends must be samples, and
    # the mean is the bin's mean (a reader loses no extreme of the run)
    t = hopping["time"].values
    bins = 97
    for var in ("a", "bdot", "N"):
        v = hopping[var].values
        out = plots.binned(t, {var: v}, bins)
        edges = np.linspace(t[0], t[-1], bins + 1)
        k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, bins - 1)
        used = np.unique(k)
        assert out["time"].size == used.size  # empty bins dropped
        for j, b in enumerate(used):
            mine = v[k == b]
            assert out[f"{var}_lo"][j] == mine.min() and out[f"{var}_hi"][j] == mine.max()
            assert out[var][j] == pytest.approx(mine.mean(), rel=1e-12, abs=1e-12)
            assert t[k == b][0] <= out["time"][j] <= t[k == b][-1]


def test_binned_leaves_nan_out_of_a_bin():
    t = np.arange(10.0)
    v = np.array([1.0, np.nan, 3.0, np.nan, np.nan, 5.0, 6.0, 7.0, 8.0, 9.0])
    out = plots.binned(t, {"v": v}, 5)  # bins of two samples
    np.testing.assert_allclose(out["v"], [1.0, 3.0, 5.0, 6.5, 8.5])
    np.testing.assert_allclose(out["v_lo"], [1.0, 3.0, 5.0, 6.0, 8.0])
    np.testing.assert_allclose(out["v_hi"], [1.0, 3.0, 5.0, 7.0, 9.0])


def _shares_loop(ds, bins):
    t0, t1, vals = plots._state_runs(ds)
    edges = np.linspace(t0[0], t1[-1], bins + 1)
    share = np.zeros((bins, len(STATE_NAMES)))
    for a, b, v in zip(t0, t1, vals):
        for k in range(bins):
            share[k, v] += max(0.0, min(b, edges[k + 1]) - max(a, edges[k]))
    return edges, share / np.diff(edges)[:, None]


@pytest.mark.parametrize("bins", [1, 7, 400])
def test_state_shares_match_the_loop(hopping, bins):
    edges, got = plots.state_shares(hopping, bins)
    want_edges, want = _shares_loop(hopping, bins)
    np.testing.assert_allclose(edges, want_edges)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got.sum(axis=1), 1.0, atol=1e-12)
    if bins >= 400:
        assert (got.max(axis=1) < 1).sum() > 10  # bins that mix states


@pytest.mark.parametrize("bins", [None, 400])
def test_strip_polygons_cover_each_state_for_its_time(hopping, bins):
    # the drawn strip: each state's polygon has the area (time x height 1)
    # the run spends in that state, whether exact bands or per-bin shares
    (edges, shares), _ = plots.state_strip(hopping, bins)
    t0, t1, vals = plots._state_runs(hopping)
    for code in range(len(STATE_NAMES)):
        time_in = float(((t1 - t0) * (vals == code)).sum())
        x, y = plots.strip_outline(edges, shares, code)
        assert _polygon_area(x, y) == pytest.approx(time_in, rel=1e-9, abs=1e-9)
        assert y.min() >= -1e-12 and y.max() <= 1 + 1e-12
