"""The run's summary: one Markdown table, one column per model, each number
under the model that produced it (the run with its tau twin's verdict and
cost; the other model's run when that is the comparison)."""

import math

import panel as pn

from vibtrans.analysis.summary import CHAOS_LYAPUNOV, summarize
from vibtrans_explorer.session.controller import CANCELLED, TWIN_LABEL
from vibtrans_explorer.session.state import MAP_MATERIAL, SPHERE
from vibtrans_explorer.session.urlstate import literal

SUMMARY_ROWS = [
    "drift <v*> (mean over the run)",
    "drift, final 10%",
    "steady?",
    "regime",
    "chaos verdict",
    "take-offs",
    "contact fraction (final 10%)",
    "rolls?",
    "cost",
    "in SI units",
]
# the summary before the first run: the same lines (so the page keeps its layout)
PLACEHOLDER_SUMMARY = "\n".join(
    ["**Click the map or pick a paper point.**", "", "| quantity | value |", "|---|---|"]
    + [f"| {row.split(' (')[0]} | - |" for row in SUMMARY_ROWS]
)


NO_DEVICE = "- (run a device"  # the SI row of a run that is no device's (UnitsPanel.si_text)
STALE_LINE = "**⚠ Changed since this run: press Run.**"
# over the previous run's table after a cancel: what the page shows is that run
CANCELLED_LINE = f"**{CANCELLED}** The summary, figures and downloads shown are still the previous run's:"
PREVIOUS_RUN = "the previous run's (the run after it was cancelled)"


def twin_words(s, twin_name):
    """What the tau twin did, plainly: where its trajectory parted from the
    run's (x* more than 1 a0 apart, analysis.divergence_time) or that it
    never did, and whether its drift differs (analysis.chaos_verdict)."""
    if s.twin_chaotic is None:
        return ""
    t = s.divergence_time
    path = (
        f"the {twin_name}'s trajectory parted from this run after {t:.4g} periods"
        if t is not None and math.isfinite(t)
        else f"the {twin_name}'s trajectory stayed within 1 a0 of this run's"
    )
    drift = "its drift differs" if s.twin_chaotic else "its drift is the same"
    return f"; {path}, and {drift}"


def chaos_verdict(result):
    """The chaos row of a RunResult, in words: the Lyapunov exponent's
    verdict where the run measured one (and what the tau twin did beside
    it when one ran), else the twin's."""
    twin_name = f"{TWIN_LABEL} twin"
    s = result.summary
    twin = twin_words(s, twin_name)
    if s.lyapunov == float("-inf"):
        return (
            "regular: the point rides the surface after the ramp, and each detachment "
            f"forgets its past (Lyapunov exponent -inf){twin}"
        )
    if s.lyapunov is not None:
        word = "chaotic" if s.chaotic else "regular"
        return (
            f"{word}: Lyapunov exponent {s.lyapunov:.2g} per period "
            f"({'>' if s.chaotic else '<='} {CHAOS_LYAPUNOV:g}){twin}"
        )
    if result.twin_unneeded:
        return f"not checked: no take-off (the {twin_name} is drawn below)"
    if s.chaotic is None:
        return "not checked"
    return f"{'chaotic' if s.chaotic else 'robust'}{twin}"


def run_cost(scene, s):
    """The cost of run `s` (of `scene`'s fidelity and integrator, its own
    model), and its twin's apart."""
    how = "closed form, scanned" if s.model == "point-mass" else f"{scene.fidelity}, {scene.integrator}"
    text = f"{s.steps:,} steps, {s.seconds:.3f} s ({how})"
    if s.twin_steps:
        text += f"; its tau twin: {s.twin_steps:,} steps, {s.twin_seconds:.3f} s"
    return text


def rolls_words(s):
    """Whether the run's particle rolls (the library's Summary.rolling), and
    the largest rolled arc within one contact episode (docs/MODEL.md
    section 11)."""
    if s.rolling == "none":
        return (
            "no: a material point has no size"
            if s.model == "point-mass"
            else "no: it slides without turning (the paper's particle)"
        )
    arc = (
        ""
        if s.max_episode_roll is None
        else f"; largest rolled arc within one contact {s.max_episode_roll:.3g} a0"
    )
    return f"yes: {s.rolling}{arc}"


def si_words(s, si):
    """The SI row of run `s`: the device's drift `si` (UnitsPanel.si_text),
    said to be this run's mean, which depends on its length, where its
    drift is not steady (Summary.steady, the "steady?" row's verdict)."""
    if not si or si.startswith(NO_DEVICE) or s.steady:
        return si
    verdict = s.steadiness.split(":")[0]  # not steady, chaotic, launched, not judged
    return f"{verdict} (see steady?): {si}; this run's mean, which depends on its length"


def _summary_column(scene, s, chaos, si):
    """One model's values, in the order of SUMMARY_ROWS, as Markdown (the
    library's words shown as they are)."""
    return [
        f"**{s.drift_velocity:.4g}**",
        *map(
            literal,
            [
                f"{s.final_drift_velocity:.4g}",
                s.steadiness,
                s.regime,
                chaos,
                f"{s.takeoffs} ({s.takeoffs_per_period:.3g} per period at the end)",
                f"{s.contact_fraction:.3f}",
                rolls_words(s),
                run_cost(scene, s),
                si_words(s, si) or "-",
            ],
        ),
    ]


def profile_words(scene):
    """The run title's words on the particle's profile: none for the
    sphere; the profile run, or that the material point (a rigid point)
    ran without it."""
    if scene.profile == SPHERE:
        return ""
    if scene.model == "point-mass":
        return f", profile {literal(scene.profile)} (not used: the material point is rigid)"
    return f", profile {literal(scene.profile)}"


def rolling_heading(scene):
    """The run title's words on the particle's rolling: none where it does
    not roll."""
    if scene.rolling == "none":
        return ""
    j = scene.inertia_ratio
    name = {"solid": "a solid sphere", "shell": "a thin shell"}.get(scene.rolling, "j")
    return f", rolling ({name}, j = {j:.4g})" if name != "j" else f", rolling (j = {j:.4g})"


def summary_table(scene, s, chaos, si, other, twin):
    """The run's summary as a Markdown table, one column per model: the run
    (with its tau twin's verdict and cost), and the other model's run when
    that is the comparison, each number under the model that produced it."""
    cols = [_summary_column(scene, s, chaos, si)]
    heads = [s.model]
    if other is not None and twin is None and other.attrs["model"] != scene.model:
        so = summarize(other)
        cols.append(_summary_column(scene, so, "not checked (comparison run)", None))
        heads.append(so.model)
    # (a '|' inside a cell, e.g. "|v*| <= 0.1", is escaped: `literal`)
    rows = [f"| {row} | " + " | ".join(c[i] for c in cols) + " |" for i, row in enumerate(SUMMARY_ROWS)]
    material = (
        ""
        if (scene.theta, scene.nu) == tuple(MAP_MATERIAL.values())
        else f", theta = {scene.theta:.4g}, nu = {scene.nu:.4g} (the maps: "
        f"{MAP_MATERIAL['theta']:g}, {MAP_MATERIAL['nu']:g})"
    )
    return "\n".join(
        [
            f"**{scene.model}: A\\* = {scene.amplitude:.4g}, m\\* = {scene.mass:.4g}, "
            f"mu = {scene.mu:g}{material}{profile_words(scene)}{rolling_heading(scene)}**",
            "",
            "| quantity | " + " | ".join(heads) + " |",
            "|---" * (len(heads) + 1) + "|",
        ]
        + rows
    )


class SummaryView:
    """The summary pane: the placeholder, a running run's status, then the
    table of the run shown (`si_text(v_star, scene)`: its drift in SI units,
    from the Units tab)."""

    def __init__(self, si_text, width=None):
        self.si_text = si_text
        self.device_run = False  # the run shown is the device's (its SI values shown)
        self._table = None  # the run shown's table
        self._stale = False
        self._cancelled = False  # a run after it was cancelled: said over its table
        kw = {"sizing_mode": "stretch_width"} if width is None else {"width": width}
        self.pane = pn.pane.Markdown(PLACEHOLDER_SUMMARY, name="summary", **kw)

    def say(self, text):
        self.pane.object = text

    def show(self, result):
        s = result.summary
        si = self.si_text(s.drift_velocity, result.scene)
        self.device_run = not si.startswith(NO_DEVICE)
        self._table = summary_table(result.scene, s, chaos_verdict(result), si, result.other, result.twin)
        self._stale = self._cancelled = False
        self._render()

    def cancelled(self):
        """A run was cancelled: said, over the table of the run still shown
        (the previous one), if any, until the next run is shown; its figures
        and downloads are that run's too."""
        if self._table is None:
            self.pane.object = CANCELLED
            return
        self._cancelled = True
        self._render()

    def mark_stale(self, stale):
        """Mark the run shown as changed since (or not)."""
        self._stale = stale
        if self._table is not None:
            self._render()

    def _render(self):
        """The table under what is said of it: that a later run was
        cancelled (so this is the previous run), then that the state has
        changed since it ran; in that order whatever the order of events."""
        said = [CANCELLED_LINE] * self._cancelled + [STALE_LINE] * self._stale
        self.pane.object = "\n\n".join([*said, self._table])
