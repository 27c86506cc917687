"""Each fidelity preset keeps its stated drift error (fidelity.STATED_DRIFT_ERROR).

Source: an independent, much finer run of the same model (the quick
work-precision study's reference, 2048 steps per period / 320 per contact time
scale, AB4), on non-chaotic paper points (the tau + 1e-3 twin agrees).  The
stated bounds are the issue's targets (preview 5%, standard 0.5%); the full
study measured 1.6% and 0.01% (`vibtrans bench --work-precision`).
"""

import pytest

from vibtrans.core import fidelity as F
from vibtrans.tools import workprecision as WP


@pytest.fixture(scope="module")
def quick_study():
    ladder = tuple(WP.Setting(name, *F.FIDELITY[name]) for name in ("preview", "standard"))
    return WP.study(quick=True, ladder=ladder)


@pytest.mark.parametrize("preset", ["preview", "standard"])
@pytest.mark.parametrize("integrator", ["ab4", "verlet"])
def test_preset_within_its_stated_drift_error(quick_study, preset, integrator):
    pts = [p for p in quick_study if p.setting == preset and p.integrator == integrator and not p.chaotic]
    assert len(pts) == len(WP.QUICK_CASES)
    for p in pts:
        assert p.stable, p
        assert p.drift_error <= F.STATED_DRIFT_ERROR[preset], p


def test_preview_is_cheaper_than_standard(quick_study):
    steps = {
        s: sum(p.steps for p in quick_study if p.setting == s and p.integrator == "ab4")
        for s in ("preview", "standard")
    }
    assert steps["standard"] >= 1.5 * steps["preview"]
