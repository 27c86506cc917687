"""The lines over a map on demand made for a profile other than the sphere
(a cone, a power law).  The jumping boundary and the resonances drawn over the maps
come from the shipped threshold curve (assets/maps/vertical.nc), the
sphere's; on a cone's map they would be wrong.  The profile's own threshold
curve costs about half of a default map on demand's points (measured,
docs/DYNAMICS.md section 5), so such a map draws its linear contact
resonance m*_res = N*'(1)/(4 pi^2) (a closed form) instead, and its title
says that the jumping boundary is the sphere's only."""

import math

import holoviews as hv
import numpy as np
import pytest

from vibtrans.core.profiles import FlatSphereProfile, PowerLawProfile, linear_resonance_mass
from vibtrans_explorer.server import data
from vibtrans_explorer.views import map as M

hv.extension("bokeh")  # as the explorer does


def _flat_sphere_stiffness(gamma):
    """N*'(1) of the flat-ended sphere from its closed form (docs/MODEL.md
    section 10): N* = (gamma^2 s + 2 s^3/3) / (same at a* = 1),
    s^2 = (sqrt(gamma^4 + 4 a*^2) - gamma^2) / 2, so dN*/da* = (a*/s) / norm
    (gamma^2 + 2 s^2 = sqrt(gamma^4 + 4 a*^2))."""
    s1 = math.sqrt((math.sqrt(gamma**4 + 4.0) - gamma**2) / 2)
    return 1.0 / (s1 * (gamma**2 * s1 + 2 * s1**3 / 3))


@pytest.mark.parametrize(
    "spec, stiffness",
    [
        ("sphere", 1.5),
        ("cone", 2.0),
        ("power:3", 4.0 / 3.0),
        ("power:1.5", 5.0 / 3.0),
        ("flat-sphere:1", _flat_sphere_stiffness(1.0)),
        ("flat-sphere:0.3", _flat_sphere_stiffness(0.3)),
    ],
)
def test_the_linear_resonance_is_the_closed_form(spec, stiffness):
    # z = C r^n: N* = a*^((n+1)/n), N*'(1) = (n+1)/n; the flat: its closed form
    # (the flat-ended sphere's law is tabulated in s: 1e-6 relative)
    assert linear_resonance_mass(spec) == pytest.approx(
        stiffness / (4 * math.pi**2), rel=1e-6 if "flat" in spec else 1e-15
    )


def test_the_documented_values():
    # docs/DYNAMICS.md section 5: 0.038 (sphere), 0.051 (cone), 0.034
    # (power:3), 0.029 (flat-sphere:1)
    got = [round(linear_resonance_mass(s), 3) for s in ("sphere", "cone", "power:3", "flat-sphere:1")]
    assert got == [0.038, 0.051, 0.034, 0.029]
    assert linear_resonance_mass(PowerLawProfile(1.0)) == linear_resonance_mass("cone")
    assert linear_resonance_mass(FlatSphereProfile(1.0)) == linear_resonance_mass("flat-sphere:1")


def _window_map(profile):
    """A window of the shipped map standing for a map on demand of `profile`
    (the lines do not depend on the drift's values, only on the profile)."""
    ds = data.drift_map("deformable", 0.3).sel(log_amplitude=slice(-1, 1), log_mass=slice(-2, 0)).copy()
    ds.attrs = dict(ds.attrs)
    if profile != "sphere":
        ds.attrs["scene_profile"] = profile
    else:
        ds.attrs.pop("scene_profile", None)
    return ds


def _lines(el):
    """(x data of the element's curves, y of its horizontal lines)."""
    curves = [np.asarray(c.dimension_values(0)) for c in el.traverse(lambda x: x, [hv.Curve])]
    hlines = [float(h.data) for h in el.traverse(lambda x: x, [hv.HLine])]
    return curves, hlines


WINDOW = ((-1.0, 1.0), (-2.0, 0.0))


def test_a_spheres_map_on_demand_draws_the_shipped_lines():
    vertical = data.vertical_curve()
    el = M.computed_element(_window_map("sphere"), "map", "deformable", WINDOW, 0.1, "grey")
    curves, hlines = _lines(el)
    boundary = np.log10(vertical["threshold_amplitude"].values)
    assert any(c.shape == boundary.shape and np.array_equal(c, boundary) for c in curves)
    assert vertical.attrs["resonance_fundamental_log_mass"] in hlines
    title = M.computed_figure(_window_map("sphere"), "map", "deformable", WINDOW, 0.1, "grey").title.text
    assert title == "map"


@pytest.mark.parametrize("profile", ["cone", "power:3", "flat-sphere:1"])
def test_a_profiles_map_on_demand_draws_its_linear_resonance_and_says_why(profile):
    vertical = data.vertical_curve()
    el = M.computed_element(_window_map(profile), "map", "deformable", WINDOW, 0.1, "grey")
    curves, hlines = _lines(el)
    boundary = np.log10(vertical["threshold_amplitude"].values)
    # the sphere's boundary and resonances: not drawn on the profile's map
    assert not any(c.shape == boundary.shape and np.array_equal(c, boundary) for c in curves)
    assert vertical.attrs["resonance_fundamental_log_mass"] not in hlines
    assert vertical.attrs["resonance_subharmonic_log_mass"] not in hlines
    # its own linear resonance: N*'(1)/(4 pi^2)
    assert hlines == [math.log10(linear_resonance_mass(profile))]
    title = M.computed_figure(_window_map(profile), "map", "deformable", WINDOW, 0.1, "grey").title.text
    assert title.startswith("map\n")
    assert f"{profile}'s linear resonance m* = {linear_resonance_mass(profile):.3g}" in title
    assert title.endswith("(closed form)\nno jumping boundary: the one shipped is the sphere's")


def test_the_material_points_map_keeps_its_lines_whatever_the_profile():
    # the material point is rigid: its jumping boundary 1/(4 pi^2 m*) holds
    # for every profile (a map on demand of it carries no profile)
    el = M.computed_element(_window_map("cone"), "map", "point-mass", WINDOW, 0.1, "grey")
    curves, _ = _lines(el)
    rigid = np.log10(data.vertical_curve()["point_mass_threshold_amplitude"].values)
    assert any(c.shape == rigid.shape and np.array_equal(c, rigid) for c in curves)
