"""The Units tab: a device in SI units -> its (A*, m*) (a marker on the
map), a0, c_R, and the run's drift and time in SI units when the scene run
is that device; for a run of it that rolls, whether its contact patch stayed
put (`rolling_note`: the library's design.rolling_warning)."""

import functools
import math

import panel as pn
import param

from vibtrans.core import units
from vibtrans.core.params import MAP_LOG_AMPLITUDE, MAP_LOG_MASS
from vibtrans.products import design
from vibtrans.products.design import CUSTOM_MATERIAL
from vibtrans_explorer.session.state import DEVICE_FIELDS, SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS, within
from vibtrans_explorer.session.urlstate import literal
from vibtrans_explorer.views import inputs


def refusal_alert(css):
    """An alert of what a tab refused, hidden while it has nothing to say."""
    return pn.pane.Alert(
        "", alert_type="danger", visible=False, sizing_mode="stretch_width", css_classes=[css]
    )


def same_scene(device, scene):
    """Is `scene` the device's (log10 A*, log10 m*, theta, nu), as run
    (state.device_scene_values: unrounded)?"""
    la, lm, theta, nu = device
    return (
        math.isclose(la, math.log10(scene.amplitude), rel_tol=0, abs_tol=1e-12)
        and math.isclose(lm, math.log10(scene.mass), rel_tol=0, abs_tol=1e-12)
        and scene.theta == theta
        and scene.nu == nu
    )


class UnitsPanel(pn.viewable.Viewer):
    """The state's device (SI units, the same form as the Design tab's) ->
    (A*, m*) marker on the map, a0, c_R, drift in m/s.

    on_run(say): run the device's scene (the explorer's; it refuses while a
    field is invalid, and says why by say(text) too)."""

    marker = param.Tuple(default=None, allow_None=True, length=2)

    def __init__(self, state, on_run, **params):
        super().__init__(**params)
        self.state, self.on_run = state, on_run
        self.info = pn.pane.Markdown(sizing_mode="stretch_width", name="units-info")
        self.warnings = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-units-warnings"])
        # the last run of the device, if it rolled: its contact patch's check
        self.run_note = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-units-rolling"])
        # why the tab's Run did not run, beside its button
        self.refusal = refusal_alert("vt-units-refusal")
        state.param.watch(self._update, [*DEVICE_FIELDS, "invalid"])
        self._update()

    def normalized(self):
        return self.state.device()

    def _update(self, *events):
        errors = self.state.device_errors()
        if not errors:
            self.say_refusal("")  # (the fields it named are valid now)
        try:
            if errors:  # (the state keeps the last valid values: none is shown)
                raise ValueError(" · ".join(errors))
            n = self.normalized()
            A_star, m_star, a0, profile = self.state.device_tip()  # (the tip's a0)
        except (ValueError, TypeError) as exc:
            why = str(exc) if errors else literal(exc)
            self.info.object = (
                f"**Invalid input:** {why}\n\n*The device's A\\*, m\\*, a0 and "
                f"its marker on the map are shown once it is valid.*"
            )
            self.warnings.object = ""
            self.marker = None
            return
        la = math.log10(A_star) if A_star > 0 else -math.inf
        lm = math.log10(m_star)
        inside = within(la, lm, MAP_LOG_AMPLITUDE, MAP_LOG_MASS)
        runnable = within(la, lm, SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS)
        self.marker = (la, lm) if runnable else None
        where = (
            "yes: green diamond"
            if inside
            else "outside the map (the scene runs all the same)"
            if runnable
            else f"no: outside the explorer's range (log10 A* in {list(SCENE_LOG_AMPLITUDE)}, "
            f"log10 m* in {list(SCENE_LOG_MASS)})"
        )
        shape = None if self.state.tip == "sphere" else literal(self.state.tip_shape().name)
        tip = [] if shape is None else [f"| tip (the Design tab's) | {shape}: profile `{profile}` |"]
        self.info.object = "\n".join(
            [
                "| quantity | value |",
                "|---|---|",
                f"| A* | {A_star:.4g} (log10 {la:.4g}) |",
                f"| m* | {m_star:.4g} (log10 {lm:.4g}) |",
                f"| a0 | {a0:.3e} m |",
                *tip,
                f"| wave period | {units.duration_text(1.0 / n.frequency)} |",
                f"| Rayleigh speed c_R | {n.c_R:.0f} m/s |",
                f"| r(nu), theta | {n.r:.3f}, {n.theta:.3f} |",
                f"| on the map | {where} |",
            ]
        )
        self.warnings.object = "\n\n".join(
            f"**Warning:** {literal(w.message)}" for w in device_warnings(self.state)
        )

    def run(self):
        """The tab's Run: the device's scene (`on_run`), or why not, said
        beside the button (and over the page)."""
        self.say_refusal("")
        self.on_run(say=self.say_refusal)

    def say_refusal(self, text):
        """Say why the tab's Run did not run ("": nothing to say)."""
        self.refusal.param.update(object=text, visible=bool(text))

    def device_of(self, scene):
        """The device (units.NormalizedScene) if `scene` is the device's of
        the Units and Design tabs (its A*, m*, theta, nu and profile), else
        None."""
        try:
            n, values = self.normalized(), self.state.device_scene_values()
            profile = self.state.device_tip()[3]
        except (ValueError, TypeError):
            return None
        return n if same_scene(values, scene) and scene.profile == profile else None

    def si_text(self, v_star, scene):
        """The drift in m/s if `scene` is a device's, else a hint: another
        scene has no device."""
        n = self.device_of(scene)
        if n is None:
            return "- (run a device from the Units or Design tab to see it in SI units)"
        run = units.duration_text(scene.periods / n.frequency)
        # a0 f v* (the tip's a0; the sphere's: the converter's own)
        v = (
            n.drift_velocity_si(v_star)
            if self.state.tip == "sphere"
            else self.state.device_tip()[2] * n.frequency * v_star
        )
        return (
            f"{v:.3e} m/s; the run, {scene.periods:g} periods, lasts {run} "
            f"(the device of the Units and Design tabs)"
        )

    def rolling_note(self, result):
        """A run that rolls, of the device: its largest rolled arc within
        one contact (the run's max_episode_roll, in a0, times the device's
        a0) against the device's contact radius (design.rolling_warning:
        a warning at or above design.ROLL_CONTACT_FRACTION of it), as
        Markdown; "" for a run that does not roll or is no device's."""
        roll = result.summary.max_episode_roll
        if roll is None or self.device_of(result.scene) is None:
            return ""
        try:
            a0 = self.state.device_tip()[2]
            radius = design.device_quantities(
                self.state.device_spec(), shape=self.state.tip_shape()
            ).contact_radius
            warning = design.rolling_warning(roll, a0, radius)
        except (ValueError, TypeError) as exc:
            return f"*The run's rolled arc could not be checked: {literal(exc)}*"
        if warning is not None:
            return f"**Warning (the run):** {literal(warning.message)}"
        return (
            f"*The run's particle rolled at most {roll:.3g} a0 = {roll * a0:.3g} m within "
            f"one contact, {roll * a0 / radius:.2g} of the contact radius {radius:.3g} m "
            f"(below {design.ROLL_CONTACT_FRACTION:g}): its contact patch stayed put, as "
            f"the model assumes.*"
        )

    def show_run(self, result):
        """A run shown: its rolling note (`rolling_note`) in the tab; returned."""
        self.run_note.object = self.rolling_note(result)
        return self.run_note.object

    def period_seconds(self, scene):
        """The wave period in seconds if `scene` is a device's, else None."""
        n = self.device_of(scene)
        return None if n is None else 1.0 / n.frequency

    def __panel__(self):
        go = pn.widgets.Button(
            label="Run this device's scene", color="primary", css_classes=["vt-units-run", "vt-ack-run"]
        )
        go.on_click(lambda event: self.run())
        self.form = device_form(self.state, width=260)
        return pn.Column(
            pn.pane.Markdown("### Device in SI units (the Design tab's too)"),
            *self.form,
            go,
            self.refusal,
            self.warnings,
            self.run_note,
            self.info,
        )


DEVICE_LABELS = {
    "radius": "particle radius (m)",
    "frequency": "frequency (Hz)",
    "amplitude": "vertical wave amplitude (m)",
    "preload": "pre-load (N)",
}


def device_form(device, width=150):
    """The device's widgets (the Units and Design tabs show one form: these,
    bound to the state's device; the Design tab alone, to its own
    design.Device): materials, custom materials' properties, radius,
    frequency, amplitude, pre-load."""
    select = functools.partial(pn.widgets.Select.from_param, width=width)
    customs = {
        k: inputs.read_back(
            pn.widgets.TextInput.from_param(
                device.param[f"{k}_custom"],
                label=f"{k}: E (Pa), nu, rho (kg/m^3)",
                width=width,
                visible=pn.bind(lambda v: v == CUSTOM_MATERIAL, device.param[k]),
                css_classes=[f"vt-{k}-custom"],
            )
        )
        for k in ("substrate", "particle")
    }
    return [
        select(device.param.substrate, label="substrate", css_classes=["vt-substrate"]),
        customs["substrate"],
        select(device.param.particle, label="particle", css_classes=["vt-particle"]),
        customs["particle"],
        *[inputs.NumberField(device, k, v, width=width) for k, v in DEVICE_LABELS.items()],
    ]


def device_warnings(state):
    """The model's validity warnings for the state's device with its tip
    (the Design tab's: a0 below the interatomic spacing, the contact radius,
    adhesion, the tip's edge slope and a cone's apex)."""
    try:
        return list(design.validity_warnings(state.device_spec(), shape=state.tip_shape()))
    except (ValueError, TypeError):
        return []
