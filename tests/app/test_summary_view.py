"""The explorer's run summary names the model behind each number and lists
the tau twin's cost apart (with the point-mass comparison, not only the
deformable numbers; the cost row does not silently add
the twin's steps)."""

from vibtrans import paper_scene, simulate
from vibtrans.analysis.summary import summarize, twin_scene
from vibtrans_explorer.views.summary import summary_table as _summary_table


def _cells(table, row):
    line = next(l for l in table.splitlines() if l.startswith(f"| {row} |"))
    return [c.strip() for c in line.strip("|").split(" | ")][1:]


def test_a_point_mass_comparison_has_its_own_column():
    scene = paper_scene(6).replace(periods=20.0)
    ds, pm = simulate(scene), simulate(scene.replace(model="point-mass"))
    s, so = summarize(ds), summarize(pm)
    table = _summary_table(scene, s, "not checked", None, pm, None)
    assert "| quantity | deformable | point-mass |" in table
    drift = _cells(table, "drift <v*> (mean over the run)")
    assert drift == [f"**{s.drift_velocity:.4g}**", f"**{so.drift_velocity:.4g}**"]
    cost = _cells(table, "cost")
    assert cost[0].startswith(f"{s.steps:,} steps") and "(standard, ab4)" in cost[0]
    # the material point is not time-stepped: no fidelity or integrator to name
    assert cost[1].startswith(f"{so.steps:,} steps") and "closed form" in cost[1]


def test_the_twin_cost_is_listed_apart():
    scene = paper_scene(4).replace(periods=20.0)  # jumps: the twin runs
    ds, twin = simulate(scene), simulate(twin_scene(scene))
    s = summarize(ds, twin)
    table = _summary_table(scene, s, "robust", None, twin, twin)
    assert "| quantity | deformable |" in table and "point-mass" not in table
    (cost,) = _cells(table, "cost")
    assert cost.startswith(f"{s.steps:,} steps") and s.steps == ds.attrs["steps"]
    assert f"its tau twin: {s.twin_steps:,} steps" in cost and s.twin_steps == twin.attrs["steps"]


def test_a_bar_in_a_cell_does_not_break_the_table():
    scene = paper_scene(3).replace(periods=20.0)  # no drift: "|v*| <= 0.1"
    s = summarize(simulate(scene))
    assert "|" in s.regime
    table = _summary_table(scene, s, "not checked", None, None, None)
    assert all(
        line.count("|") - line.count("\\|") == 3
        for line in table.splitlines()
        if line.startswith("| ") and "quantity" not in line
    )


def test_the_chaos_row_gives_the_lyapunov_exponents_verdict_and_the_twins():
    """The issue's example (log10 A* = 0.5, log10 m* = -2): the exponent says
    chaotic, the tau twin happened to agree; the row says both, the
    exponent's verdict first (it decides)."""
    from vibtrans_explorer.session.controller import interpret
    from vibtrans_explorer.views.summary import chaos_verdict

    scene = paper_scene(1).replace(amplitude=10**0.5, mass=10**-2.0)
    ds = simulate(scene, lyapunov=True)
    row = chaos_verdict(interpret(scene, ds, simulate(twin_scene(scene)), "tau + 0.001"))
    assert row.startswith("chaotic: Lyapunov exponent 0.1") and "(> 0.01)" in row
    # what the twin did, plainly (not "agrees" for a twin whose
    # trajectory parted): its path parted, its mean drift the same
    assert "the tau + 0.001 twin's trajectory parted from this run after" in row
    assert row.endswith("and its drift is the same")
    regular = paper_scene(6).replace(periods=400.0)
    row = chaos_verdict(interpret(regular, simulate(regular, lyapunov=True), None, None))
    assert row.startswith("regular: Lyapunov exponent") and "(<= 0.01)" in row
