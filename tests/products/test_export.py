"""Headless figure export (vibtrans.products.export, `vibtrans export`): no display,
no browser; exact pixel sizes; labels in SVG; PDF; the app's figures and the
exported ones plot the same data; bad command lines exit 2 with one line.

Everything runs on a tiny drift map (4 amplitudes x 3 masses, 50 periods:
not square, so a swapped axis cannot fit) and a tiny threshold curve made
here, a hand-made 4 x 3 map with a distinct colour in every cell (the
drawn pixels against the data, cell by cell), and short scenes."""

import json
import os
import subprocess
import sys
from pathlib import Path

import holoviews as hv
import numpy as np
import pytest
import xarray as xr
from budget import budget

from vibtrans import cli
from vibtrans.analysis.summary import twin_scene
from vibtrans.core.kernels.contact import STATE_NAMES
from vibtrans.core.params import paper_scene
from vibtrans.core.simulate import memory_snapshot, simulate
from vibtrans.core.threshold import threshold_curve
from vibtrans.maps.sweep import Sweep, open_map, run_sweep
from vibtrans.products import export, plots

ROOT = Path(__file__).resolve().parents[2]
PERIODS = 50


@pytest.fixture(scope="module")
def maps_dir(tmp_path_factory):
    """A tiny shipped-maps folder: deformable-mu0.3.zarr and vertical.nc."""
    d = tmp_path_factory.mktemp("assets") / "maps"
    d.mkdir()
    sweep = Sweep(
        np.array([-0.5, 0.5, 1.5, 2.5]),
        np.array([-2.0, -0.5, 1.0]),
        model="deformable",
        mu=0.3,
        periods=PERIODS,
    )
    run_sweep(sweep, str(d / "deformable-mu0.3.zarr"), workers=1, progress=False, executor="threads")
    vertical = threshold_curve(np.array([-2, -1.4, 0]), periods=PERIODS, workers=1, progress=False)
    vertical.to_netcdf(d / "vertical.nc")
    return d


@pytest.fixture(scope="module")
def map_ds(maps_dir):
    return open_map(str(maps_dir / "deformable-mu0.3.zarr"))


@pytest.fixture(scope="module")
def vertical(maps_dir):
    return export.load_vertical(maps_dir)


@pytest.fixture(scope="module")
def run4():
    """Paper point 4 (hopping), short, with its full-resolution window."""
    scene = paper_scene(4, periods=PERIODS)
    return simulate(scene, window=(PERIODS - 2, PERIODS), samples_per_period=export.OVERVIEW_SAMPLES)


@pytest.fixture
def no_display(monkeypatch):
    for k in ("DISPLAY", "WAYLAND_DISPLAY"):
        monkeypatch.delenv(k, raising=False)


def _png_size(path):
    from PIL import Image

    with Image.open(path) as im:
        return im.size


# ------------------------------------------------------------------ files
@pytest.mark.slow
def test_png_pixel_size_is_dpi_times_inches(no_display, tmp_path, map_ds, vertical):
    cases = [
        (export.export_heatmap, (map_ds,), dict(vertical=vertical), 6.0, 4.0, 50),
        (export.export_vertical, (vertical,), {}, 5.0, 3.5, 40),
        (export.export_memory, (memory_snapshot(paper_scene(1), t=3.3),), {}, 10.0, 3.0, 30),
        (export.export_trajectory, (simulate(paper_scene(4, periods=10), window=(8, 10)),), {}, 7.0, 9.0, 40),
    ]
    for i, (fn, args, kw, w, h, dpi) in enumerate(cases):
        out = tmp_path / f"f{i}.png"
        fn(*args, out, width=w, height=h, dpi=dpi, **kw)
        assert out.stat().st_size > 2000, fn.__name__
        assert _png_size(out) == (round(w * dpi), round(h * dpi)), fn.__name__


@pytest.mark.slow
def test_svg_keeps_axis_labels_as_text_and_pdf_is_pdf(no_display, tmp_path, map_ds, vertical, run4):
    svg = tmp_path / "map.svg"
    export.export_heatmap(map_ds, svg, vertical=vertical, dpi=50)
    text = svg.read_text()
    assert "log10 A*" in text and "log10 m*" in text
    svg2 = tmp_path / "traj.svg"
    export.export_trajectory(run4, svg2, dpi=30)
    text = svg2.read_text()
    assert "t* (periods)" in text and "contact state" in text
    assert "a* (a0)" in text and "y* (a0)" in text  # each on its own axis
    pdf = tmp_path / "vertical.pdf"
    export.export_vertical(vertical, pdf)
    assert pdf.read_bytes()[:5] == b"%PDF-" and pdf.stat().st_size > 2000


@pytest.mark.slow
def test_memory_diagram_figure_marks_stick_and_slip(tmp_path):
    snap = memory_snapshot(paper_scene(1), t=100.6)
    assert 0 < snap["stick_depth"] < snap["a"]  # partial slip at this instant
    out = tmp_path / "mem.svg"
    export.export_memory(snap, out, dpi=30)
    text = out.read_text()
    for label in ("stick core", "slip annulus", "u = b* - w", "h (contact depth, a0)"):
        assert label in text
    circle = plots.contact_circle(snap)
    radii = sorted(np.hypot(*p.array([0, 1]).T).max() for p in circle if isinstance(p, hv.Polygons))
    assert np.allclose(radii, [np.sqrt(snap["stick_depth"]), np.sqrt(snap["a"])], rtol=1e-3)


def test_standalone_html_has_inline_resources(tmp_path, run4):
    out = tmp_path / "traj.html"
    export.export_trajectory(run4, out)
    text = out.read_text()
    assert "<html" in text.lower() and "Bokeh" in text
    assert 'src="https://cdn.bokeh.org' not in text and "cdn.bokeh.org/bokeh/release" not in text
    for title in (
        "whole run: normal: a*(t), y*(t)",
        plots.SHARES_TITLE,
        "t* in [48, 50]: normal",
        "t* (periods)",
    ):
        assert title in text


# ------------------------------------------------------------------ headless
HEADLESS = r"""
import json, os, shutil, subprocess, sys
started = []
_real = subprocess.Popen.__init__
def _spy(self, args, *a, **k):
    started.append(str(args))
    return _real(self, args, *a, **k)
subprocess.Popen.__init__ = _spy
from vibtrans import cli
codes = [cli.main(argv) for argv in json.loads(sys.argv[1])]
bad = sorted(m for m in sys.modules if any(s in m.lower() for s in
             ("selenium", "playwright", "webdriver", "pyppeteer", "chromedriver")))
print(json.dumps({"codes": codes, "bad": bad, "started": started,
                  "chromium": shutil.which("chromium") or shutil.which("chrome"),
                  "display": os.environ.get("DISPLAY"),
                  "backend": __import__("matplotlib").get_backend()}))
"""


@pytest.mark.slow
def test_cli_export_in_a_subprocess_without_display_or_browser(tmp_path, maps_dir):
    empty_bin = tmp_path / "bin"
    empty_bin.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PATH"] = str(empty_bin)  # no chromium (or anything) can be found
    argvs = [
        [
            "export",
            "heatmap",
            "--maps",
            str(maps_dir),
            "--out",
            str(tmp_path / "m.png"),
            "--dpi",
            "40",
            "--width",
            "5",
            "--height",
            "4",
        ],
        [
            "export",
            "trajectory",
            "--log-amplitude",
            "2.5",
            "--log-mass",
            "0",
            "--periods",
            str(PERIODS),
            "--out",
            str(tmp_path / "t.pdf"),
            "--dpi",
            "30",
        ],
    ]
    proc = subprocess.run(
        [sys.executable, "-c", HEADLESS, json.dumps(argvs)],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=budget(240),
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    assert res["codes"] == [0, 0]
    assert res["bad"] == [], res["bad"]
    assert res["chromium"] is None and res["display"] is None
    assert res["backend"].lower() == "agg"
    assert not any(s in c.lower() for c in res["started"] for s in ("chrom", "firefox", "driver"))
    assert _png_size(tmp_path / "m.png") == (200, 160)
    assert (tmp_path / "t.pdf").read_bytes()[:5] == b"%PDF-"


# ------------------------------------------------------------------ same data
def _capture(monkeypatch):
    """Record the HoloViews objects and matplotlib figures export renders."""
    seen = {"objs": [], "figs": []}
    real = export.render

    def spy(obj, *args, **kwargs):
        fig = real(obj, *args, **kwargs)
        seen["objs"].append(obj)
        seen["figs"].append(fig)
        return fig

    monkeypatch.setattr(export, "render", spy)
    return seen


def _app_map(maps_dir):
    """The explorer's map, built the way app/explorer.py builds it, from the
    app's data loader pointed at maps_dir."""
    from assetsfolder import point_assets

    from vibtrans_explorer.server import data

    shipped = data.ASSETS
    point_assets(maps_dir.parent)
    try:
        ds = data.drift_map("deformable", 0.3)
        vertical = data.vertical_curve()
    finally:
        point_assets(shipped)
    el = plots.drift_map(ds, v0=0.1, chaotic="grey", title="deformable, mu = 0.3")
    el = el * plots.jumping_boundary(vertical, "deformable") * plots.resonance_lines(vertical)
    return el * plots.paper_points("deformable")


@pytest.mark.slow
def test_app_and_cli_heatmaps_plot_the_same_data(monkeypatch, tmp_path, maps_dir):
    export.ensure_backends()
    hv.Store.set_current_backend("bokeh")  # as in the explorer's process
    app_el = _app_map(maps_dir)
    seen = _capture(monkeypatch)
    assert (
        cli.main(
            ["export", "heatmap", "--maps", str(maps_dir), "--out", str(tmp_path / "m.png"), "--dpi", "40"]
        )
        == 0
    )
    assert hv.Store.current_backend == "bokeh"  # exporting left the app's backend alone
    cli_el = seen["objs"][0]
    # the elements' data
    first = lambda obj, kind: obj.traverse(lambda x: x, [kind])[0]  # noqa: E731
    app_img, cli_img = first(app_el, hv.Image), first(cli_el, hv.Image)
    for dim in ("C", "v"):
        np.testing.assert_array_equal(
            app_img.dimension_values(dim, flat=False), cli_img.dimension_values(dim, flat=False)
        )
    np.testing.assert_array_equal(first(app_el, hv.Curve).array(), first(cli_el, hv.Curve).array())
    np.testing.assert_array_equal(first(app_el, hv.Points).array(), first(cli_el, hv.Points).array())
    # and what each backend drew: bokeh's image source vs matplotlib's AxesImage
    from bokeh.models import GlyphRenderer, Line
    from bokeh.models import Image as BkImage

    bk = hv.render(app_el, backend="bokeh")
    rends = [r for r in bk.renderers if isinstance(r, GlyphRenderer)]
    bk_img = next(r for r in rends if isinstance(r.glyph, BkImage)).data_source.data["image"][0]
    ax = next(a for a in seen["figs"][0].axes if a.images)
    mpl_img = np.ma.filled(ax.images[0].get_array().astype(float), np.nan)
    assert mpl_img.shape == bk_img.shape == (3, 4)  # (mass rows, amplitude columns)
    # bokeh's row 0 is at the bottom (smallest m*); matplotlib's is at the
    # bottom with origin 'lower', at the top with 'upper': one orientation only
    if ax.images[0].origin == "upper":
        mpl_img = np.flipud(mpl_img)
    np.testing.assert_allclose(mpl_img, bk_img, equal_nan=True)
    bk_line = next(r for r in rends if isinstance(r.glyph, Line)).data_source.data
    mpl_line = next(line for line in ax.lines if len(line.get_xdata()) == 3)
    np.testing.assert_allclose(mpl_line.get_xdata(), bk_line["log_amplitude"])
    np.testing.assert_allclose(mpl_line.get_ydata(), bk_line["log_mass"])


# ------------------------------------------------------------------ pixels
LA = np.array([-2.5, -1.0, 0.5, 2.0])  # 4 amplitudes (columns), spacing 1.5
LM = np.array([-4.0, -1.0, 2.0])  # 3 masses (rows), spacing 3
CHAOTIC_CELL = (1, 2)  # (amplitude index, mass index): grey


def _hand_map():
    """A drift map (open_map's layout) with a distinct colour C in each
    cell: |v*| from 0.2 to 2000 on both sides of the wave, one chaotic cell,
    none inside the white band."""
    v = np.array(
        [[-2000.0, 3.0, -0.5], [40.0, -8.0, 700.0], [-0.2, 150.0, -60.0], [12.0, -300.0, 0.7]]
    )  # (amplitude, mass)
    chaotic = np.zeros(v.shape, dtype=np.int8)
    chaotic[CHAOTIC_CELL] = 1
    return xr.Dataset(
        {
            "drift_velocity": (("log_amplitude", "log_mass"), v),
            "chaotic": (("log_amplitude", "log_mass"), chaotic),
        },
        coords={"log_amplitude": LA, "log_mass": LM},
        attrs={"scene_model": "deformable", "scene_mu": 0.3, "scene_periods": 2000.0},
    )


def test_heatmap_pixels_are_the_data_at_known_cells(monkeypatch, tmp_path):
    # Source: closed form (the colour quantity C of plots.colour_scale, docs/MODEL.md
    # section 4) at each cell, read back from what was drawn: the image
    # arrays of both backends located by their extents, and the PNG's pixel
    # at each cell centre (x = log10 A* to the right, y = log10 m* upwards).
    from PIL import Image

    ds = _hand_map()
    c = plots.colour_scale(ds["drift_velocity"].values)  # (amplitude, mass)
    assert np.unique(c).size == c.size  # every cell distinct
    seen = _capture(monkeypatch)
    dpi = 60
    out = tmp_path / "m.png"
    export.export_heatmap(ds, out, dpi=dpi, width=7.0, height=5.2)
    fig = seen["figs"][0]
    ax = next(a for a in fig.axes if a.images)
    img = ax.images[0]
    arr = np.ma.filled(img.get_array().astype(float), np.nan)
    assert arr.shape == (LM.size, LA.size)
    left, right, bottom, top = img.get_extent()
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    assert x0 < x1 and y0 < y1  # neither axis reversed
    png = np.asarray(Image.open(out).convert("RGB")).astype(int)
    height = png.shape[0]
    scale = dpi / fig.dpi
    for i, la in enumerate(LA):
        for j, lm in enumerate(LM):
            # the image array's cell at (la, lm), from its extent and origin
            col = int((la - left) / (right - left) * LA.size)
            row = int((lm - bottom) / (top - bottom) * LM.size)
            if img.origin == "upper":
                row = LM.size - 1 - row
            expected = np.nan if (i, j) == CHAOTIC_CELL else c[i, j]
            np.testing.assert_allclose(arr[row, col], expected, equal_nan=True, err_msg=f"cell {la}, {lm}")
            # the PNG pixel at the cell centre
            px, py = ax.transData.transform((la, lm)) * scale
            rgb = png[height - 1 - int(py), int(px)]
            if (i, j) == CHAOTIC_CELL:
                assert np.ptp(rgb) <= 3 and 140 <= rgb[0] <= 170, rgb  # grey
            else:
                want = np.round(np.array(img.to_rgba(c[i, j])[:3]) * 255)
                assert np.abs(rgb - want).max() <= 2, (la, lm, rgb, want)
    # bokeh (the explorer): row 0 at the bottom, x, y, dw, dh the extent
    from bokeh.models import GlyphRenderer
    from bokeh.models import Image as BkImage

    bk = hv.render(export.heatmap_figure(ds), backend="bokeh")
    r = next(r for r in bk.renderers if isinstance(r, GlyphRenderer) and isinstance(r.glyph, BkImage))
    bimg = np.asarray(r.data_source.data["image"][0], dtype=float)
    src = r.data_source.data
    gx, gy, gdw, gdh = (float(src[k][0]) for k in ("x", "y", "dw", "dh"))
    assert bimg.shape == (LM.size, LA.size)
    for i, la in enumerate(LA):
        for j, lm in enumerate(LM):
            col = int((la - gx) / gdw * LA.size)
            row = int((lm - gy) / gdh * LM.size)
            expected = np.nan if (i, j) == CHAOTIC_CELL else c[i, j]
            np.testing.assert_allclose(bimg[row, col], expected, equal_nan=True)


def _capture_trajectory(monkeypatch):
    """Record the trajectory figures (definitions and matplotlib figures)
    export draws."""
    seen = {"defs": [], "figs": []}
    real = export.render_trajectory

    def spy(figure, *args, **kwargs):
        fig = real(figure, *args, **kwargs)
        seen["defs"].append(figure)
        seen["figs"].append(fig)
        return fig

    monkeypatch.setattr(export, "render_trajectory", spy)
    return seen


def _drawn_on(fig, ax, right):
    """The axes a panel `ax`'s line is drawn on: its twin (the right axis,
    same place) when `right`, else ax itself."""
    if not right:
        return ax
    (twin,) = [o for o in fig.axes if o is not ax and o.bbox.bounds == ax.bbox.bounds]
    return twin


def _band(ax, colour):
    """(x, lo, hi) of the min-max band of `colour` drawn in `ax`."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import to_rgb

    (band,) = [
        c
        for c in ax.collections
        if isinstance(c, PolyCollection) and np.allclose(c.get_facecolor()[0][:3], to_rgb(colour))
    ]
    v = band.get_paths()[0].vertices
    x, inverse = np.unique(v[:, 0], return_inverse=True)
    lo = np.full(x.size, np.inf)
    hi = np.full(x.size, -np.inf)
    np.minimum.at(lo, inverse, v[:, 1])
    np.maximum.at(hi, inverse, v[:, 1])
    return x, lo, hi


def _strip_areas(ax):
    """{state name: area of its polygons} of a drawn state strip, and the
    names and colours of its legend."""
    from matplotlib.colors import to_hex

    area = {}
    colours = {to_hex(c): n for n, c in zip(STATE_NAMES, plots.STATE_COLORS.values())}
    for c in ax.collections:
        for path in c.get_paths():
            x, y = path.vertices.T
            name = colours[to_hex(c.get_facecolor()[0])]
            area[name] = area.get(name, 0.0) + 0.5 * abs(
                np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))
            )
    legend = {
        t.get_text(): to_hex(h.get_facecolor())
        for t, h in zip(ax.get_legend().get_texts(), ax.get_legend().legend_handles)
    }
    return area, legend


@pytest.mark.slow
def test_exported_trajectory_draws_the_whole_run_and_the_window(monkeypatch, tmp_path):
    # What the trajectory figure shows, as the explorer's export button
    # makes it (the run with its last FRAGMENT periods at full resolution,
    # OVERVIEW_SAMPLES per period, its tau twin): the panels and their
    # legends; the whole run as per-bin means inside min-max bands that hold
    # every sample (a sample outside its band, a lost spike, fails); the
    # window sample by sample; the state strips covering each state for the
    # time the run spends in it, in the states' colours, named in a legend.
    scene = paper_scene(8, periods=PERIODS)  # hops; chaotic: has a twin
    ds = simulate(
        scene, window=(PERIODS - plots.FRAGMENT, PERIODS), samples_per_period=plots.OVERVIEW_SAMPLES
    )
    twin = simulate(twin_scene(scene), samples_per_period=plots.OVERVIEW_SAMPLES)
    seen = _capture_trajectory(monkeypatch)
    out = tmp_path / "t.png"
    export.export_trajectory(ds, out, twin=twin, dpi=30)
    assert _png_size(out) == (330, 390)  # 11 x 13 in at 30 dpi
    fig = seen["figs"][0]
    # rows x (whole run, window); the right axes (twins) come after them
    axes = np.array(fig.axes[:12]).reshape(6, 2)
    titles = [[ax.get_title() for ax in row] for row in axes]
    note = plots.BINNED_NOTE
    assert titles == [
        ["whole run: normal: a*(t), y*(t)" + note, "t* in [48, 50]: normal: a*(t), y*(t)"],
        ["tangential: b*(t), x*(t)" + note, "tangential: b*(t), x*(t)"],
        ["forces: N*, T*" + note, "forces: N*, T*"],
        ["relative tangential velocity b*'" + note, "relative tangential velocity b*'"],
        ["contact state (time share per bin)", "contact state"],
        ["x*(t) and its tau + 0.001 twin" + note, "x*(t) and its tau + 0.001 twin"],
    ]
    legends = [[t.get_text() for t in ax.get_legend().get_texts()] for ax in axes[[0, 1, 2, 3, 5], 0]]
    assert legends == [["a*", "y*"], ["b*", "x*"], ["N*", "T*"], ["b*'"], ["x*, tau = 50", "x*, tau + 0.001"]]
    assert fig.get_suptitle() == ("deformable: A* = 50.12, m* = 0.01, mu = 0.3")
    t = ds["time"].values
    edges = np.linspace(t[0], t[-1], plots.OVERVIEW_BINS + 1)
    k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, plots.OVERVIEW_BINS - 1)
    used, j = np.unique(k, return_inverse=True)
    frag = t >= PERIODS - plots.FRAGMENT
    for row, lines in enumerate(plots.panel_spec(False, split_velocity=True)):
        right = plots.right_columns([var for var, _, _ in lines[2]])
        for var, label, colour in lines[2]:
            v = ds[var].values
            ok = np.isfinite(v)
            # (a right-axis quantity is drawn on its panel's twin axes)
            on = [_drawn_on(fig, axes[row, col], var in right) for col in (0, 1)]
            # whole run: the band holds every sample, its ends are samples
            x, lo, hi = _band(on[0], colour)
            assert x.size == used.size
            assert np.all(lo[j][ok] <= v[ok]) and np.all(v[ok] <= hi[j][ok]), var
            np.testing.assert_array_equal(np.isin(lo, v), True)
            np.testing.assert_array_equal(np.isin(hi, v), True)
            line = next(ln for ln in on[0].lines if ln.get_label() == label)
            # a right-axis line dashed (solid, x* hid b* where they coincide)
            assert line.get_linestyle() == ("--" if var in right else "-"), (var, right)
            np.testing.assert_allclose(line.get_ydata(), plots.binned(t, {var: v}, plots.OVERVIEW_BINS)[var])
            # the window: every sample, nothing else
            line = next(ln for ln in on[1].lines if ln.get_label() == label)
            np.testing.assert_array_equal(line.get_xdata(), t[frag])
            np.testing.assert_array_equal(line.get_ydata(), v[frag])
    # the strips: each state's area is its time (the strip is 1 high)
    t0, t1, vals = plots._state_runs(ds)
    for col, (a, b) in enumerate([(t[0], t[-1]), (PERIODS - plots.FRAGMENT, t[-1])]):
        area, legend = _strip_areas(axes[4, col])
        spent = {
            n: float((np.clip(t1, a, b) - np.clip(t0, a, b))[vals == c].sum())
            for c, n in enumerate(STATE_NAMES)
        }
        spent = {n: s for n, s in spent.items() if s > 0}
        assert area.keys() == spent.keys()
        for n in spent:
            assert area[n] == pytest.approx(spent[n], rel=1e-9), n
        assert legend == {n: plots.STATE_COLORS[STATE_NAMES.index(n)] for n in spent}
    assert len(spent) >= 1 and len(_strip_areas(axes[4, 0])[0]) >= 2  # hops: >= 2 states
    # the twin: dashed black, its own samples
    twin_line = next(ln for ln in axes[5, 1].lines if ln.get_label() == "x*, tau + 0.001")
    assert twin_line.get_linestyle() == "--" and twin_line.get_color() == "black"
    tt = twin["time"].values
    np.testing.assert_array_equal(twin_line.get_xdata(), tt[tt >= PERIODS - plots.FRAGMENT])


# ------------------------------------------------------------------ paper
@pytest.mark.slow
def test_paper_export_writes_each_figure_and_an_index(monkeypatch, tmp_path, maps_dir, capsys):
    # a subset of the figures keeps this fast: the vertical curve, the maps
    # and the chaotic point with its twin
    subset = {n: export.PAPER_FIGURES[n] for n in (2, 3, 11)}
    monkeypatch.setattr(export, "PAPER_FIGURES", subset)
    out = tmp_path / "paper"
    assert (
        cli.main(
            ["export", "paper", "--out", str(out), "--maps", str(maps_dir), "--periods", "20", "--dpi", "30"]
        )
        == 0
    )
    names = sorted(p.name for p in out.iterdir())
    assert names == ["fig02-vertical.png", "fig03-drift-maps.png", "fig11-point8.png", "index.md"]
    for name in names[:-1]:
        assert (out / name).stat().st_size > 2000
    index = (out / "index.md").read_text()
    for n in (2, 3, 11):
        assert f"## Fig. {n}:" in index
    assert "vibtrans export trajectory --point 8 --out fig11-point8.png --twin --periods 20" in index
    assert "point-mass map missing" in index  # the tiny assets have no point-mass map
    assert "log10 A* = 1.7" in index


# ------------------------------------------------------------------ bad input
BAD = [
    (["export", "heatmap", "--out", "x.jpg"], "out"),
    (["export", "heatmap", "--out", "x.png", "--dpi", "abc"], "dpi"),
    (["export", "heatmap", "--out", "x.png", "--dpi", "10"], "dpi"),
    (["export", "heatmap", "--out", "x.png", "--dpi", "150.5"], "dpi"),
    (["export", "heatmap", "--out", "x.png", "--width", "0"], "width"),
    (["export", "heatmap", "--out", "x.png", "--height", "nan"], "height"),
    (["export", "heatmap", "--out", "x.png", "--v0", "-1"], "v0"),
    (["export", "heatmap", "--out", "x.png", "--mu", "0.77"], "mu"),
    (["export", "heatmap", "--out", "x.png", "--maps", "/no/such/dir"], "maps"),
    (["export", "trajectory", "--out", "x.png"], "--point"),
    (["export", "trajectory", "--out", "x.png", "--point", "11"], "point"),
    (
        ["export", "trajectory", "--out", "x.png", "--log-amplitude", "inf", "--log-mass", "0"],
        "log_amplitude",
    ),
    (["export", "trajectory", "--out", "x.png", "--point", "4", "--periods", "-5"], "periods"),
    (
        ["export", "trajectory", "--out", "x.png", "--point", "4", "--periods", "20", "--window", "10", "30"],
        "window",
    ),
    (["export", "memory", "--out", "x.png", "--point", "1"], "t"),
    (["export", "memory", "--out", "x.png", "--point", "1", "--t", "-1"], "t"),
    (["export", "memory", "--out", "x.png", "--point", "9", "--t", "1"], "model"),
    (["export", "paper", "--out", "figs.png"], "out"),
    (["export", "movie", "--out", "x.png"], "kind"),
]


@pytest.mark.slow
@pytest.mark.parametrize("argv,name", BAD, ids=[" ".join(a[1:4]) + f"-{i}" for i, (a, _) in enumerate(BAD)])
def test_bad_cli_input_exits_2_with_one_line(argv, name, maps_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    if "--maps" not in argv:
        argv = argv + ["--maps", str(maps_dir)]
    try:
        code = cli.main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert name in lines[0], lines[0]
    assert not list(tmp_path.glob("x.*")) and not (tmp_path / "figs.png").exists()


@pytest.mark.slow
def test_export_bench_measures_each_format(monkeypatch):
    # `vibtrans bench --export` runs and reports what it says (times are
    # printed, never asserted); a short run keeps this quick
    from vibtrans.tools import bench

    real = bench.paper_scene
    monkeypatch.setattr(bench, "paper_scene", lambda point: real(point, periods=20.0))
    r = bench.export_bench(quick=True)
    assert r["point"] == 8 and r["samples"] > r["twin_samples"] > 0
    for fmt in ("png", "svg", "html"):
        assert 0 < r[f"{fmt}_cpu_seconds"] and 0 < r[f"{fmt}_seconds"] < float("inf")
        assert r[f"{fmt}_over_reference"] == pytest.approx(
            r[f"{fmt}_cpu_seconds"] / r["reference_cpu_seconds"]
        )


def test_standalone_html_while_the_current_document_is_destroyed(tmp_path, run4):
    """A download callback in the server runs where Bokeh's curdoc() is a
    session's document that may already be destroyed (a closed page's); the
    trajectory's .html would then never arrive (AttributeError
    '_js_event_callbacks' in bokeh.embed's new document).  The export makes
    its own Document and does not read curdoc()."""
    from bokeh.document import Document
    from bokeh.io.doc import patch_curdoc

    session = object()  # what a server session registers
    gone = Document()
    gone.on_change_dispatch_to(session)
    gone.destroy(session)
    out = tmp_path / "traj.html"
    with patch_curdoc(gone):
        export.export_trajectory(run4, out)
    text = out.read_text()
    assert "<html" in text.lower() and "t* (periods)" in text


def test_exported_trajectory_gives_y_its_own_axis(run4):
    """The exported trajectory draws y* on an axis of its own, not a*'s (the app gives
    it an axis of its own at the right, plots.RIGHT_AXIS); the PNG/SVG/PDF
    (matplotlib) and the HTML (Bokeh) are drawn from one figure definition
    (plots.trajectory_figure), whose panels say which lines go right."""
    import matplotlib.pyplot as plt
    from bokeh.models import LinearAxis

    figure = plots.trajectory_figure(run4)
    normal = next(p for p in figure.columns[0] if "normal: a*(t), y*(t)" in p.title)
    assert normal.right == ("y",) and normal.axis_labels == ("a* (a0)", "y* (a0)")
    fig = export.render_trajectory(figure)
    try:
        main = next(ax for ax in fig.axes if ax.get_title() == normal.title)
        twins = [ax for ax in fig.axes if ax is not main and ax.bbox.bounds == main.bbox.bounds]
        assert len(twins) == 1
        by_label = {main.get_ylabel(): main, twins[0].get_ylabel(): twins[0]}
        y = [tr for tr in normal.traces if tr.var == "y"][0]
        a = [tr for tr in normal.traces if tr.var == "a"][0]
        # y*'s line on an axis labelled y*, a*'s on one labelled a*
        assert any(np.array_equal(line.get_ydata(), y.value) for line in by_label["y* (a0)"].lines)
        assert any(np.array_equal(line.get_ydata(), a.value) for line in by_label["a* (a0)"].lines)
        assert not any(np.array_equal(line.get_ydata(), y.value) for line in by_label["a* (a0)"].lines)
    finally:
        plt.close(fig)
    layout = export.trajectory_bokeh(figure)
    right = [
        ax
        for ax in layout.select({"type": LinearAxis})
        if ax.y_range_name == "right" and ax.axis_label == "y* (a0)"
    ]
    assert len(right) == 2  # the whole run's panel and the fragment's
