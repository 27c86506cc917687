"""What a run means: drift, regimes, steadiness and the chaos check
(`summary`), and the dynamics of the stroboscopic map (`dynamics`: sections,
period-one orbits, continuation, orbit diagrams)."""
