"""Start-up times of `vibtrans serve` and `vibtrans simulate`, cold (a new
empty NUMBA_CACHE_DIR) and warm (the same, filled): the server's first page
(with its CPU seconds) and "kernels ready"; simulate's whole command (paper
point 4).  The machine's load is printed beside the figures.

    python -m devtools.firstpage [--rounds 2] [--json]
"""

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

SIMULATE = ["simulate", "--log-amplitude", "2.5", "--log-mass", "0", "--json"]


def _port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _vibtrans():
    exe = shutil.which("vibtrans", path=str(Path(sys.executable).parent))
    return [exe] if exe else [sys.executable, "-m", "vibtrans.cli"]


def _cpu_s(pid):
    """CPU seconds (user + system) the process has used."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def serve_times(cache, timeout=900):
    """(seconds to the first page, CPU seconds by then, seconds to kernels ready, log)."""
    port = _port()
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    with tempfile.TemporaryFile(mode="w+") as log:
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [*_vibtrans(), "serve", "--port", str(port)],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            cwd=tempfile.gettempdir(),
        )
        page = ready = cpu = None
        try:
            while time.perf_counter() - t0 < timeout and (page is None or ready is None):
                if proc.poll() is not None:
                    break
                if page is None:
                    try:
                        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=120) as r:
                            if r.status == 200:
                                page = time.perf_counter() - t0
                                cpu = _cpu_s(proc.pid)
                    except OSError:
                        pass
                if ready is None:
                    log.seek(0)
                    if "kernels ready" in log.read():
                        ready = time.perf_counter() - t0
                time.sleep(0.1)
        finally:
            proc.terminate()
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
            log.seek(0)
            text = log.read()
    return page, cpu, ready, text


def simulate_time(cache):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    t0 = time.perf_counter()
    subprocess.run(
        [*_vibtrans(), *SIMULATE], env=env, check=True, capture_output=True, cwd=tempfile.gettempdir()
    )
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.firstpage", description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--skip-simulate", action="store_true")
    a = ap.parse_args(argv)
    rows = []
    for _ in range(a.rounds):
        cache = Path(tempfile.mkdtemp(prefix="vibtrans-numba-cold-"))
        try:
            load = os.getloadavg()[0]
            cold_page, cold_cpu, cold_ready, cold_log = serve_times(cache)
            warm_page, warm_cpu, warm_ready, _ = serve_times(cache)
            row = {
                "load_1min": round(load, 2),
                "serve_cold_first_page_s": cold_page,
                "serve_cold_first_page_cpu_s": cold_cpu,
                "serve_cold_kernels_ready_s": cold_ready,
                "serve_warm_first_page_s": warm_page,
                "serve_warm_first_page_cpu_s": warm_cpu,
                "serve_warm_kernels_ready_s": warm_ready,
            }
            if not a.skip_simulate:
                shutil.rmtree(cache)
                cache.mkdir()
                row["simulate_cold_s"] = simulate_time(cache)
                row["simulate_warm_s"] = simulate_time(cache)
            row["cold_server_log"] = [ln for ln in cold_log.splitlines() if ln.startswith("vibtrans serve:")]
            rows.append(row)
        finally:
            shutil.rmtree(cache, ignore_errors=True)
    if a.json:
        print(json.dumps(rows, indent=1))
    else:
        for r in rows:
            for k, v in r.items():
                if k != "cold_server_log":
                    print(f"{k:>28}: {v if not isinstance(v, float) else round(v, 1)}")
            print("\n".join("    " + ln for ln in r["cold_server_log"]))
    return rows


if __name__ == "__main__":
    main()
