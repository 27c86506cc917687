"""The Units tab: a device in SI units -> its (A*, m*) (a marker on the
map), a0, c_R, and the run's drift and time in SI units when the scene run
is that device."""
import math

import panel as pn
import param

from vibtrans.core import units
from vibtrans.core.params import MAP_LOG_AMPLITUDE, MAP_LOG_MASS

from .. import inputs
from ..state import SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS, within


def same_scene(n, marker, scene):
    """Is `scene` the device `n` (at the explorer's 3-decimal log10 A*, m*)?"""
    return (round(marker[0], 3) == round(math.log10(scene.amplitude), 3)
            and round(marker[1], 3) == round(math.log10(scene.mass), 3)
            and scene.theta == n.theta and scene.nu == n.nu)


class UnitsPanel(pn.viewable.Viewer):
    """SI inputs -> (A*, m*) marker on the map, a0, c_R, drift in m/s.

    on_run(la, lm, theta, nu): run the device's scene (the explorer's);
    on_error(text): say why it cannot."""

    substrate = param.Selector(default="glass", objects=sorted(units.MATERIALS))
    particle = param.Selector(default="steel", objects=sorted(units.MATERIALS))
    radius_mm = param.Number(default=0.5, bounds=(1e-4, 100.0), doc="particle radius, mm")
    frequency_khz = param.Number(default=108.0, bounds=(1e-3, 1e6), doc="wave frequency, kHz")
    amplitude_nm = param.Number(default=1.0, bounds=(0.0, 1e6), doc="vertical wave amplitude, nm")
    preload_mN = param.Number(default=0.0, bounds=(0.0, 1e6), doc="pre-load, mN")
    marker = param.Tuple(default=None, allow_None=True, length=2)

    def __init__(self, on_run, on_error, **params):
        super().__init__(**params)
        self.on_run, self.on_error = on_run, on_error
        self._other = None      # (NormalizedScene, its name): a device run from another tab
        self.info = pn.pane.Markdown(sizing_mode="stretch_width", name="units-info")
        self.param.watch(self._update, ["substrate", "particle", "radius_mm", "frequency_khz",
                                        "amplitude_nm", "preload_mN"])
        self._update()

    def normalized(self):
        return units.to_normalized(self.substrate, self.particle, self.radius_mm * 1e-3,
                                   self.frequency_khz * 1e3, self.amplitude_nm * 1e-9,
                                   preload=self.preload_mN * 1e-3)

    def _update(self, *events):
        try:
            n = self.normalized()
        except (ValueError, TypeError) as exc:
            self.info.object = f"**Invalid input:** {exc}"
            self.marker = None
            return
        la = math.log10(n.A_star) if n.A_star > 0 else -math.inf
        lm = math.log10(n.m_star)
        inside = within(la, lm, MAP_LOG_AMPLITUDE, MAP_LOG_MASS)
        runnable = within(la, lm, SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS)
        self.marker = (la, lm) if runnable else None
        where = ("yes: green diamond" if inside else
                 "outside the map (the scene runs all the same)" if runnable else
                 f"no: outside the explorer's range (log10 A* in {list(SCENE_LOG_AMPLITUDE)}, "
                 f"log10 m* in {list(SCENE_LOG_MASS)})")
        self.info.object = "\n".join([
            "| quantity | value |", "|---|---|",
            f"| A* | {n.A_star:.4g} (log10 {la:.3f}) |",
            f"| m* | {n.m_star:.4g} (log10 {lm:.3f}) |",
            f"| a0 | {n.a0:.3e} m |",
            f"| wave period | {units.duration_text(1.0 / n.frequency)} |",
            f"| Rayleigh speed c_R | {n.c_R:.0f} m/s |",
            f"| r(nu), theta | {n.r:.3f}, {n.theta:.3f} |",
            f"| on the map | {where} |",
        ])

    def use_device(self, normalized, name):
        """A device run from another tab (the Design tab's): its runs are
        given in SI units too, named `name`."""
        self._other = (normalized, name)

    def _device_named(self, scene):
        """(units.NormalizedScene, its name) of the device `scene` is (its
        A*, m*, theta and nu): the Units tab's, else the one another tab
        ran; (None, None) if neither."""
        try:
            n = self.normalized()
        except (ValueError, TypeError):
            n = None
        if n is not None and self.marker is not None and same_scene(n, self.marker, scene):
            return n, "the Units tab's device"
        if self._other is not None:
            n, name = self._other
            if same_scene(n, (math.log10(n.A_star), math.log10(n.m_star)), scene):
                return n, name
        return None, None

    def device_of(self, scene):
        """The device (units.NormalizedScene) if `scene` is the Units tab's
        device or the one another tab ran, else None."""
        return self._device_named(scene)[0]

    def si_text(self, v_star, scene):
        """The drift in m/s if `scene` is a device's, else a hint: another
        scene has no device."""
        n, name = self._device_named(scene)
        if n is None:
            return "- (run a device from the Units or Design tab to see it in SI units)"
        run = units.duration_text(scene.periods / n.frequency)
        return (f"{n.drift_velocity_si(v_star):.3e} m/s; the run, {scene.periods:g} periods, "
                f"lasts {run} ({name})")

    def period_seconds(self, scene):
        """The wave period in seconds if `scene` is a device's, else None."""
        n = self.device_of(scene)
        return None if n is None else 1.0 / n.frequency

    def _go(self, event):
        if self.marker is None:
            self.on_error("The Units tab's device is not a scene the explorer can run: "
                          "see its table (invalid input, or outside the range).")
            return
        la, lm = self.marker
        n = self.normalized()
        self.on_run(round(la, 3), round(lm, 3), n.theta, n.nu)

    def __panel__(self):
        go = pn.widgets.Button(name="Run this device's scene", button_type="primary")
        go.on_click(self._go)
        labels = {"radius_mm": "particle radius (mm)", "frequency_khz": "frequency (kHz)",
                  "amplitude_nm": "vertical wave amplitude (nm)", "preload_mN": "pre-load (mN)"}
        fields = [inputs.NumberField(self, k, v, width=260) for k, v in labels.items()]
        return pn.Column(
            pn.pane.Markdown("### Device in SI units"),
            pn.widgets.Select.from_param(self.param.substrate, name="substrate", width=260,
                                         css_classes=["vt-substrate"]),
            pn.widgets.Select.from_param(self.param.particle, name="particle", width=260,
                                         css_classes=["vt-particle"]),
            *fields, go, self.info)
