"""The whole-run view's data: the thinned full-resolution window and the
dominant state per time bin (vectorised; checked against the plain loop)."""
import numpy as np
import pytest

from vibtrans import Scene, plots, simulate
from vibtrans.contact import STATE_NAMES


@pytest.fixture(scope="module")
def hopping():
    # paper point 6 region: long contact + jumps, many state changes
    return simulate(Scene(amplitude=10 ** 0.22, mass=10 ** 0.33, periods=200.0),
                    window=(150.0, 200.0), samples_per_period=5)


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
    assert plots.overview_samples(hopping, window_samples=10 ** 9) is hopping
    plain = simulate(Scene(amplitude=1.0, mass=1.0, periods=20.0), samples_per_period=5)
    assert plots.overview_samples(plain) is plain
