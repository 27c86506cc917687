"""Downloads: the map shown (shipped or on demand) and the run's figures (the same as `vibtrans
export`), the run's data (netCDF, CSV) and the map's points in the zoomed
view (netCDF).  Files are written to a temporary folder, read back and the
folder removed: nothing is left on the server per click."""

import functools
import io
import os
import tempfile

import panel as pn

from vibtrans_explorer.server import data
from vibtrans_explorer.views.render import exclusively

FIGURES = [(k, f) for k in ("map", "trajectory") for f in ("png", "svg", "html")]
DATA = [("run", "nc"), ("run", "csv"), ("map-window", "nc")]


def _value(number):
    """A number as a file name spells it: 4 significant digits, no '+'."""
    return f"{number:.4g}".replace("+", "")


def download_name(kind, fmt, scene=None, map_name=None, window=None):
    """The name a download is saved under: what it holds, so that a second
    download of another scene or map does not overwrite the first.

    scene: the run's attributes (model, amplitude, mass, mu, profile);
    map_name: the map's name (a shipped map's model and mu, or a map on
    demand's); window: the zoomed view's (A* from, to, m* from, to), log10."""
    parts = ["vibtrans", kind]
    if scene is not None:
        parts += [
            scene["model"],
            f"A{_value(scene['amplitude'])}",
            f"m{_value(scene['mass'])}",
            f"mu{_value(scene['mu'])}",
        ]
        profile = scene.get("profile", "sphere")
        if scene["model"] != "point-mass" and profile != "sphere":
            parts.append(profile.replace(":", ""))
    if map_name is not None:
        parts.append(map_name)
    if window is not None:
        parts.append("la{}_{}-lm{}_{}".format(*(_value(v) for v in window)))
    name = "-".join(parts)
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name) + f".{fmt}"


def read_back(write, name):
    """The bytes `write(path)` writes to a file named `name` (in a folder
    of its own, removed after), for a download button."""
    with tempfile.TemporaryDirectory(prefix="vibtrans-") as tmp:
        out = os.path.join(tmp, name)
        write(out)
        with open(out, "rb") as f:
            return io.BytesIO(f.read())


class ExportsView:
    """The export and data buttons, made when the tab is first shown
    (`build`); the run's are disabled until a run is shown (`show`).
    map_view: the MapView (its zoomed view's ranges); button_classes: CSS
    classes every button gets as well; shown_map(): (name, Dataset) of the
    map on demand shown, or None (the shipped map of the state's model and
    mu): the map's downloads are of the map shown."""

    def __init__(self, state, map_view, answered=None, button_classes=(), shown_map=None):
        self.state, self.map_view = state, map_view
        self.shown_map = shown_map or (lambda: None)
        self.button_classes = list(button_classes)
        self.answered = answered  # called once a file is ready (or failed)
        self.result = None
        self.buttons, self.run_buttons = [], []
        self.panel = pn.Column(sizing_mode="stretch_width", name="downloads")

    def build(self):
        """The buttons, made when the tab is first shown (most sessions never
        open it); True when made now, False if they were already there."""
        if self.buttons:
            return False
        figures = [self._download(self.figure_file, "export", k, f) for k, f in FIGURES]
        datas = [self._download(self.data_file, "data", k, f) for k, f in DATA]
        self.buttons = figures + datas
        self.run_buttons = [
            b for b, (k, _) in zip(self.buttons, FIGURES + DATA) if k in ("trajectory", "run")
        ]
        self.panel.objects = [
            pn.pane.Markdown("**Export** (same figures as `vibtrans export`)"),
            pn.FlexBox(*figures),
            pn.pane.Markdown(
                "**Data** (the run: samples and events in netCDF, samples in CSV; "
                "the map's points in the zoomed view)"
            ),
            pn.FlexBox(*datas),
        ]
        return True

    def show(self, result):
        self.result = result
        for b in self.run_buttons:
            b.disabled = False

    def figure_file(self, kind, fmt):
        """The bytes of a figure download (`map` or `trajectory`)."""
        from vibtrans.products import export

        s = self.state
        if kind == "map":
            map_ds, name = self._map()
            title = None if name is None else f"<v*>, map on demand: {name}"

            def write(out):
                export.export_heatmap(map_ds, out, v0=s.v0, vertical=data.vertical_curve(), title=title)
        else:
            if self.result is None:
                raise ValueError("no run yet")

            def write(out):
                export.export_trajectory(self.result.ds, out, twin=self.result.twin)

        return exclusively(read_back, write, f"{kind}.{fmt}")

    def data_file(self, kind, fmt):
        """The bytes of a data download: the last run (`run`, netCDF or CSV)
        or the map's points inside the map's current view (`map-window`)."""
        from vibtrans.products import export

        if kind == "run":
            if self.result is None:
                raise ValueError("no run yet")
            ds = self.result.ds
            if fmt == "csv":
                return io.BytesIO(export.samples_csv(ds).encode())
        else:
            ds = export.map_window(self._map()[0], *self.map_view.view_ranges())
        return read_back(ds.to_netcdf, "data.nc")

    def _map(self):
        """(Dataset, name) of the map shown: the map on demand's, else the
        shipped map of the state's model and mu (name None)."""
        shown = self.shown_map()
        if shown is None:
            return data.drift_map(self.state.model, self.state.mu), None
        return shown[1], shown[0]

    def file_name(self, kind, fmt):
        """The name of a download of `kind` (what it holds: download_name)."""
        if kind in ("run", "trajectory"):
            return download_name(kind, fmt, scene=None if self.result is None else self.result.ds.attrs)
        shown = self.shown_map()
        map_name = f"{self.state.model}-mu{_value(self.state.mu)}" if shown is None else shown[0]
        window = [v for r in self.map_view.view_ranges() for v in r] if kind == "map-window" else None
        return download_name(kind, fmt, map_name=map_name, window=window)

    def _answering(self, make, kind, fmt, button):
        """make(kind, fmt) under the name of what it holds, then `answered`
        (also when it fails)."""
        try:
            button.filename = self.file_name(kind, fmt)
            return make(kind, fmt)
        finally:
            if self.answered is not None:
                self.answered()

    def _download(self, make, group, kind, fmt):
        """The button of one file: `make(kind, fmt)`'s bytes; a run's is
        disabled until a run is shown."""
        button = pn.widgets.FileDownload(
            filename=f"vibtrans-{kind}.{fmt}",
            label=f"{kind} .{fmt}",
            color="light",
            css_classes=[f"vt-{group}-{kind}-{fmt}", *self.button_classes],
            width=150,
            disabled=kind in ("trajectory", "run") and self.result is None,
        )
        button.callback = functools.partial(self._answering, make, kind, fmt, button)
        return button
