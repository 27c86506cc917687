"""memory_snapshots: the memory diagram at several times from one run
(the explorer's time slider scrubs through them), checked against
memory_snapshot, which runs from rest to each time on its own."""

import threading

import numpy as np
import pytest

from vibtrans import Cancelled, paper_scene
from vibtrans.core.errors import InputError
from vibtrans.core.simulate import MAX_SNAPSHOTS, memory_snapshot, memory_snapshots

KEYS = ("t", "a", "b", "h", "w", "u", "stick_depth", "state")
# Rounding only (drivers.run_memory_stops): each stop restarts the kernel's
# sin/cos rotation (a fresh cos, sin instead of a rotated one, ~1e-16) and a
# flight's landing search, and the motion after it amplifies that.  Over the
# last period of 2000 (what the explorer scrubs) the ten paper scenes, 48
# times each, preview and standard, differ by at most 4.3e-11 (scene 3),
# most by 1e-16 to 1e-13.  In a transient the amplification is larger:
# scene 9 at t* = 58-60 reaches 4e-9 within two periods.
RTOL = 1e-9


def _scene(point, periods=60.0):
    return paper_scene(point).replace(model="deformable", fidelity="preview", periods=periods)


def _same(s, ref):
    return all(np.array_equal(s[k], ref[k]) for k in KEYS)


@pytest.mark.parametrize("point, t", [(1, 0.0), (1, 0.3), (3, 7.77), (4, 41.5), (9, 12.25), (7, 60.0)])
def test_one_time_is_memory_snapshot_bit_for_bit(point, t):
    (snap,) = memory_snapshots(_scene(point), [t])
    assert _same(snap, memory_snapshot(_scene(point), t))


@pytest.mark.parametrize("point", [1, 3, 4, 7, 9])
def test_each_time_is_memory_snapshot_to_rounding(point):
    scene = _scene(point, periods=2000.0)
    times = np.linspace(1999.0, 2000.0, 48)
    snaps = memory_snapshots(scene, times)
    assert len(snaps) == times.size
    states = set()
    for t, s in list(zip(times, snaps))[::5]:
        ref = memory_snapshot(scene, float(t))
        # the same step: the same time, state and vertices
        assert s["t"] == ref["t"] and s["state"] == ref["state"]
        assert s["h"].shape == ref["h"].shape
        scale = 1.0 + abs(ref["a"]) + abs(ref["b"])
        for k in ("a", "b", "h", "w", "u", "stick_depth"):
            np.testing.assert_allclose(s[k], ref[k], rtol=0, atol=RTOL * scale, err_msg=k)
        states.add(s["state"])
    assert len(states) > 1 or point == 4  # the times cross state changes (4: in flight)


def test_the_snapshots_cover_flight_and_contact():
    """Scene 4 hops: some times fall in flight (no memory), some in contact."""
    snaps = memory_snapshots(_scene(4), np.linspace(58.0, 60.0, 33))
    in_flight = [s["h"].size == 0 for s in snaps]
    assert any(in_flight) and not all(in_flight)


def test_progress_rises_to_one_and_cancel_stops():
    seen = []
    memory_snapshots(_scene(9), [10.0, 20.0, 30.0], progress=seen.append)
    assert seen == sorted(seen) and seen[-1] == 1.0
    stop = threading.Event()
    stop.set()
    with pytest.raises(Cancelled):
        memory_snapshots(_scene(9), [10.0, 20.0, 30.0], cancel=stop)


@pytest.mark.parametrize(
    "times, says",
    [
        (None, "got None"),
        ("12", "got '12'"),
        (5.0, "got 5.0"),
        ([], "got 0 times"),
        ([1.0, float("nan")], "times[1] = nan is not"),
        ([-0.5], "times[0] = -0.5 is not"),
        ([1.0, 60.5], "times[1] = 60.5 is not"),
        ([True], "times[0] = True is not"),
        (["3"], "times[0] = '3' is not"),
        ([2.0, 2.0], "times[1] = 2.0 does not follow times[0] = 2.0"),
        ([3.0, 1.0], "times[1] = 1.0 does not follow"),
        (np.linspace(0, 1, MAX_SNAPSHOTS + 1), f"got {MAX_SNAPSHOTS + 1} times"),
    ],
)
def test_bad_times_are_named_with_their_range(times, says):
    with pytest.raises(InputError) as err:
        memory_snapshots(_scene(1), times)
    msg = str(err.value)
    assert msg.startswith("times must be") and "[0, 60] periods" in msg and says in msg


def test_a_rigid_model_has_no_memory_diagram():
    with pytest.raises(InputError, match="model must be deformable"):
        memory_snapshots(_scene(1).replace(model="point-mass"), [1.0])


def test_numpy_times_are_accepted():
    a = memory_snapshots(_scene(7), np.array([5.0, 6.5]))
    b = memory_snapshots(_scene(7), [np.float64(5.0), 6.5])
    assert all(_same(x, y) for x, y in zip(a, b))
