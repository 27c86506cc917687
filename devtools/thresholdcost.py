"""What a profile's threshold curve would cost a map on demand (issue 34,
the map's lines): the curve over the default map on demand's m* grid (33
values, log10 m* -1..1, standard fidelity, 2000 periods: the jumping
boundary's resolution there) against that map's expected points (a 9 x 9
sample of its window, decided stop, scaled to maprequest.expected_points of
its 33 x 33 grid); CPU seconds of this process and its workers, one
worker.  Run niced and say the load average:

    nice python -m devtools.thresholdcost cone

Result 2026-11-27 (docs/DYNAMICS.md section 5): the curve costs about half
the map's points, so a map on demand draws the profile's linear resonance
(a closed form) instead (app/views/map.py)."""
import json, os, sys, time, tempfile
import numpy as np
from vibtrans.core.threshold import threshold_curve
from vibtrans.maps.sweep import Sweep, run_sweep, open_map


def main():
    profile = sys.argv[1] if len(sys.argv) > 1 else "cone"
    lm = np.round(np.linspace(-1, 1, 33), 10)          # the default map on demand's m* grid
    t0 = time.process_time(); w0 = time.perf_counter()
    c0 = os.times()
    curve = threshold_curve(lm, fidelity="standard", workers=1, progress=False, profile=profile)
    c1 = os.times()
    thr_cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system) + (c1.user - c0.user)
    thr_wall = time.perf_counter() - w0
    # a 9 x 9 sample of the default window's points (decided stop, standard)
    la9, lm9 = np.round(np.linspace(-1, 1, 9), 10), np.round(np.linspace(-1, 1, 9), 10)
    values = dict(model="deformable", mu=0.3, fidelity="standard", stop="decided", chaos="lyapunov")
    if profile != "sphere":
        values["profile"] = profile
    sw = Sweep(la9, lm9, command="cost", **values)
    d = tempfile.mkdtemp()
    c0 = os.times(); w0 = time.perf_counter()
    run_sweep(sw, os.path.join(d, "m.zarr"), workers=1, progress=False)
    c1 = os.times()
    map_cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system) + (c1.user - c0.user)
    map_wall = time.perf_counter() - w0
    per_point = map_cpu / 81
    expected_points = 0.45 * 33 * 33     # maprequest.expected_points of the 33 x 33 grid
    print(json.dumps({"profile": profile, "threshold_masses": int(lm.size),
                      "threshold_cpu_s": round(thr_cpu, 2), "threshold_wall_s": round(thr_wall, 2),
                      "map_points_sampled": 81, "map_cpu_s": round(map_cpu, 2),
                      "map_wall_s": round(map_wall, 2), "map_cpu_per_point_s": round(per_point, 4),
                      "default_map_expected_cpu_s": round(per_point * expected_points, 1),
                      "threshold_share_of_map": round(thr_cpu / (per_point * expected_points), 4),
                      "resonances": {k: float(v) for k, v in curve.attrs.items()
                                     if k.startswith("resonance_") and k.endswith("_log_mass")}}))


if __name__ == '__main__':
    main()
