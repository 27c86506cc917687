"""The explorer's words: the paper points' names, the introduction, the
map's key and the run tabs' captions (no code: the views and the page read
them)."""

# The paper points' names in the selector, short (a select shows its choice
# on one line: in presentation mode at 1024 pixels, ~27 characters), and
# in full under it
POINT_LABELS = {
    1: "contact, drift -x",
    2: "contact, drift +x",
    3: "contact, no drift",
    4: "synchronous hopping",
    5: "multi-synchronous hops",
    6: "jumps, uniform drift",
    7: "jumps, accelerating",
    8: "chaotic hopping",
    9: "point mass, sliding",
    10: "point mass, chaotic",
}
POINT_DESCRIPTIONS = {
    1: "permanent contact, drift against the wave (-x)",
    2: "permanent contact, drift with the wave (+x)",
    3: "permanent contact, no drift",
    4: "synchronous hopping (hovering)",
    5: "multi-synchronous hopping",
    6: "long contact + jump, uniform drift",
    7: "long contact + jump, slow acceleration",
    8: "chaotic hopping",
    9: "point mass: symmetric sliding",
    10: "point mass: chaotic hopping",
}

# A plain-language introduction for a class (docs/MODEL.md in short)
INTRODUCTION = r"""
A small particle rests on a surface that carries a **surface acoustic
(Rayleigh) wave**. The wave travels towards **+x**; every point of the surface
runs a small ellipse once per wave period. The particle is pushed and lifted
by the surface, may slide, stick or hop, and on average it **drifts**: with
the wave (+x) or against it (-x).

* **A\*** is the wave's vertical amplitude, measured in **a0**, the amount by
  which the particle's weight squeezes its contact (a0 is tiny: nanometres).
* **m\*** compares the particle's inertia at the wave's frequency with the
  stiffness of its contact: small m\*, the particle follows the surface; large
  m\*, it cannot keep up.
* **tau** is how slowly the wave is switched on (50 periods here); time is
  counted in wave periods.
* **<v\*>** is the mean drift velocity over the run, in a0 per period. The
  map colours it: red with the wave, blue against it; **white** is "no
  drift", |v\*| <= **v0\*** (the slider sets that band).
* A hopping run measures how fast two nearby vertical motions separate (its
  **Lyapunov exponent**): when they separate, the motion is **chaotic** (grey
  on the map) and its drift is not a property of the scene. The run can also
  be repeated with tau changed by 0.001, a **tau twin** ("compare with"), as
  a second opinion: a twin that ends elsewhere also signals chaos.
* **deformable** is the particle with elastic (Hertz) contact and friction
  that remembers its loading history; the **point mass** is the classical
  rigid comparison.
* The contact's friction has three states (the colours of the contact
  strip and of the animation's contact zone): **stick**, the whole contact
  moves with the surface;
  **partial slip**, a ring at the contact's edge slides while its centre
  still sticks (Cattaneo-Mindlin);
  **total sliding**, the whole contact slides and the friction force is mu
  times the normal force.

Click the map or pick a paper point to run a scene; its trajectory appears
below the summary.

**The symbols of the figures** (docs/MODEL.md): lengths are in a0, times in
wave periods.

* **x\***, **y\***: the particle's horizontal and vertical position;
  **u_x\***, **u_y\***: the surface's under it.
* **a\*** = y\* - u_y\*: how much the contact is compressed (> 0 in contact,
  the particle is in the air when it would be negative).
* **b\***: the contact's tangential displacement (the particle against the
  surface under it, in theta mu a0); **b\*'** its rate.
* **N\***: the normal contact force, in units of the weight (N\* = a\*^(3/2),
  Hertz); **T\***: the tangential (friction) force, in units of mu times the
  weight; |T\*| = N\* when the contact slides.
"""
# the map's key for its markers (drawn on every map: shipped, on demand)
MAP_KEY = (
    "*On the map:* <span style='color:#c9a400'>●</span> yellow circle: the selected "
    "scene (the one Run runs) · <span style='color:#1a9c1a'>◆</span> green diamond: "
    "the device of the Units and Design tabs · black dots with numbers: the paper's "
    "points (the *Paper points* list)"
)

DYNAMICS_TEXT = (
    "The run's vertical motion as a dynamical system: its stroboscopic section "
    "(click it to start more orbits), its period-1 orbit's Floquet multipliers, "
    "and an orbit diagram along A* or m* (docs/DYNAMICS.md). Run a scene; "
    "computed when this tab is open."
)
ANIMATION_TEXT = (
    "**The particle on the wave**, the run's last periods at full resolution: "
    "a side view (the surface, the particle, its contact zone coloured by "
    "state) and the contact circle beside it, in step. Press play, or drag the "
    "slider."
)
MEMORY_TEXT = (
    "**Memory diagram and contact circle** (Cattaneo-Mindlin with history, "
    "deformable runs): the anchors w(h) of the springs over the contact depth, "
    "their displacements u(h) with the Coulomb cone, and the stick core inside the "
    "slip annulus. The slider scrubs through the run's last period."
)

# a run whose inputs changed since it was made: said over its views
STALE_TEXT = (
    "**Changed since this run: press Run.** The summary, figures and downloads "
    "below are of the run made before the change."
)

# presentation mode: where the sidebar's switch is
PRESENTATION_NOTE = "The **&#9776;** button at the top left hides the controls and shows it back."
