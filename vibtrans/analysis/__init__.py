"""What a run means (`summary`: drift, regime, chaos check) and the
stroboscopic map's dynamics (`dynamics`: orbits, continuation, diagrams)."""
