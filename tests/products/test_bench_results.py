"""Benchmark results as data: the record a bench writes (valid JSON, the
machine, the load, the commit; atomic, one file per run), the development
benches' writers, and the documentation's tables made from the files
(docs/_ext/benchresults.py)."""

import importlib.util
import json
import math
import os
from pathlib import Path

import pytest

from vibtrans import cli
from vibtrans.core.errors import InputError
from vibtrans.tools import bench, results

ROOT = Path(__file__).resolve().parents[2]


def _strict_json(path):
    """The file's JSON, refusing NaN and infinities (not JSON)."""

    def refuse(token):
        raise ValueError(f"{path}: {token} is not JSON")

    return json.loads(Path(path).read_text(), parse_constant=refuse)


def _check_machine(record):
    m = record["machine"]
    assert m["cores"] == os.cpu_count() and m["usable_cores"] >= 1
    assert m["cpu_model"] and m["python"] and m["packages"]["numpy"] and m["packages"]["numba"]
    for key in ("load_average_start", "load_average_end"):
        assert len(m[key]) == 3 and all(x >= 0 for x in m[key]), m
    assert record["git"] is None or (
        len(record["git"]["commit"]) == 40 and isinstance(record["git"]["dirty"], bool)
    )
    assert record["started_utc"] <= record["finished_utc"]


def test_vibtrans_bench_quick_writes_a_json_record_with_the_machine(tmp_path, capsys):
    folder = tmp_path / "results"
    cores = os.sched_getaffinity(0)
    try:
        assert cli.main(["bench", "--quick", "--json", "--results-dir", str(folder)]) == 0
    finally:
        os.sched_setaffinity(0, cores)  # the bench pins its process to one core
    printed = json.loads(capsys.readouterr().out)
    files = list(folder.glob("bench-*.json"))
    assert len(files) == 1, files
    record = _strict_json(files[0])
    assert files[0].name == results.result_name(record)
    assert record["bench"] == "bench"
    assert record["command"] == f"vibtrans bench --quick --json --results-dir {folder}"
    _check_machine(record)
    assert record["machine"]["usable_cores"] == len(cores)  # before the bench pinned itself
    r = record["results"]
    assert r["quick"] is True and r["repeat"] == printed["repeat"] == 3
    assert math.isfinite(r["deformable_over_vertical"]) and r["deformable_over_vertical"] > 0
    assert set(r["scene_seconds_2000_periods"]) == {"1", "4", "6"}
    assert "cold_start" not in r  # only with --cold-start
    assert not list(folder.glob(".*"))  # no temporary file left


def test_the_results_folder_and_file_are_checked_before_the_run(tmp_path, capsys):
    missing = tmp_path / "no" / "such"
    assert cli.main(["bench", "--results-dir", str(missing)]) == 2
    assert "bench: error: results-dir: no such folder" in capsys.readouterr().err
    assert cli.main(["bench", "--output", str(tmp_path)]) == 2  # a folder, not a file
    assert "bench: error: output:" in capsys.readouterr().err
    with pytest.raises(InputError, match="cold-start"):
        bench.main(sweep=True, cold=True)


@pytest.mark.slow
def test_cold_start_times_an_empty_cache_against_a_warm_one():
    c = bench.cold_start(warm_repeat=1)
    assert c["command"] == "vibtrans " + " ".join(bench.COLD_START_COMMAND)
    assert c["cold_seconds"] > c["warm_seconds"] > 0
    assert c["cold_over_warm"] == pytest.approx(c["cold_seconds"] / c["warm_seconds"])
    assert c["goal_cold_seconds"] == 12.0 and c["goal_cores"] == 2


def test_a_record_is_strict_json_written_whole_one_file_a_run(tmp_path):
    begun = results.begin()
    record = results.result_record(
        "loadtest",
        {"p95_s": float("nan"), "max_s": float("inf"), "points": {1: (1.5, 2)}, "ok": True},
        begun,
        command="python -m devtools.loadtest",
    )
    first = results.write_result(record, folder=tmp_path)
    second = results.write_result(record, folder=tmp_path)
    assert first.name.startswith("loadtest-") and first.name.endswith("Z.json")
    assert second.name == first.name.replace(".json", "-2.json")
    got = _strict_json(first)
    assert got["results"] == {"p95_s": None, "max_s": None, "points": {"1": [1.5, 2]}, "ok": True}
    _check_machine(got)
    exact = results.write_result(record, output=tmp_path / "mine.json")
    assert _strict_json(exact) == got
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [first.name, second.name, "mine.json"]
    )  # no temporary file left
    with pytest.raises(ValueError, match="bench"):
        results.result_record("a b/c", {}, begun)


def test_git_state_only_of_a_checkout_top(tmp_path):
    assert results.git_state(tmp_path) is None  # not a checkout
    here = results.git_state(ROOT)
    if here is not None:  # a git checkout (not an sdist)
        assert len(here["commit"]) == 40


# ---------------------------------------------------------------- the development benches
FAKE_LOADTEST = {
    "command": "python -m devtools.loadtest --sessions 1",
    "sessions": 1,
    "click_to_plot_p95_s": float("nan"),
    "errors": 0,
    "goal_errors_0": True,
    "page_loads": [["browser", 1.25]],
}


def test_the_load_test_writes_its_figures_as_a_record(tmp_path, monkeypatch):
    from devtools import loadtest

    monkeypatch.setattr(loadtest, "run", lambda a: dict(FAKE_LOADTEST))
    loadtest.main(["--sessions", "1", "--browsers", "0", "--results-dir", str(tmp_path)])
    [path] = tmp_path.glob("loadtest-*.json")
    record = _strict_json(path)
    assert record["bench"] == "loadtest" and record["command"] == FAKE_LOADTEST["command"]
    assert record["results"]["click_to_plot_p95_s"] is None
    assert record["results"]["page_loads"] == [["browser", 1.25]]
    _check_machine(record)
    assert loadtest.parse([]).results_dir.endswith(os.path.join("benchmarks", "results"))


def test_the_browser_bench_writes_its_figures_as_a_record(tmp_path, monkeypatch):
    from devtools import browserbench

    rows = {
        "map click": {
            "median_s": 0.4,
            "goal_s": None,
            "goal_met": None,
            "busy_met": True,
            "busy_within": 1,
            "slow": 1,
        }
    }
    monkeypatch.setattr(
        browserbench,
        "run",
        lambda repeats, url, log: {"rows": rows, "repeats": repeats, "failures": [], "machine": "2 cores"},
    )
    monkeypatch.setattr(browserbench, "table", lambda rows: "")
    browserbench.main(["--repeats", "1", "--results-dir", str(tmp_path)])
    [path] = tmp_path.glob("browserbench-*.json")
    record = _strict_json(path)
    assert record["command"] == f"python -m devtools.browserbench --repeats 1 --results-dir {tmp_path}"
    assert record["results"]["rows"] == rows and record["results"]["missed"] == []
    _check_machine(record)


# ---------------------------------------------------------------- the documentation's tables
def _ext():
    spec = importlib.util.spec_from_file_location("benchresults", ROOT / "docs" / "_ext" / "benchresults.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _record(finished, **results_):
    return {
        "bench": "bench",
        "schema": 1,
        "command": "vibtrans bench --quick",
        "started_utc": finished,
        "finished_utc": finished,
        "machine": {
            "cpu_model": "Test CPU",
            "cores": 2,
            "usable_cores": 2,
            "memory_gb": 4.0,
            "python": "3.11.7",
            "packages": {"numpy": "2.0", "numba": "0.60"},
            "load_average_start": [1.5, 1.0, 1.0],
            "load_average_end": [2.25, 1.0, 1.0],
        },
        "git": {"commit": "0123456789abcdef" * 2 + "01234567", "dirty": True},
        "note": None,
        "results": results_,
    }


def test_the_docs_render_the_latest_record_of_a_bench_as_a_table(tmp_path):
    ext = _ext()
    (tmp_path / "bench-20261127T100000Z.json").write_text(
        json.dumps(_record("2026-11-27T10:05:00Z", deformable_over_vertical=9.0))
    )
    (tmp_path / "bench-20261128T100000Z.json").write_text(
        json.dumps(
            _record(
                "2026-11-28T10:05:00Z",
                deformable_over_vertical=1.87654,
                repeat=7,
                cold_start={"cold_seconds": 11.5, "goal_cold_met": True},
                shortcuts_seen=[1, 2],
                note_text="a|b",
            )
        )
    )
    (tmp_path / "bench-broken.json").write_text("{not json")  # left out
    text = ext.render(tmp_path, "bench")
    lines = text.splitlines()
    assert "Measured 2026-11-28T10:05:00Z on Test CPU, 2 cores, 4 GB" in lines[0]
    assert "load average 1.5 -> 2.25" in lines[0] and "numba 0.60" in lines[0]
    assert "commit `0123456789` with uncommitted changes" in lines[0]
    assert "`bench-20261128T100000Z.json`" in lines[0]
    table = lines[lines.index("| figure | value |") :]
    assert table == [
        "| figure | value |",
        "|---|---|",
        "| `deformable_over_vertical` | 1.877 |",
        "| `repeat` | 7 |",
        "| `cold_start / cold_seconds` | 11.5 |",
        "| `cold_start / goal_cold_met` | yes |",
        "| `shortcuts_seen` | 1, 2 |",
        "| `note_text` | a\\|b |",
    ]


def test_the_docs_say_how_to_make_a_missing_result(tmp_path):
    ext = _ext()
    for folder in (tmp_path, tmp_path / "missing"):
        assert ext.render(folder, "loadtest") == (
            "No result of this bench yet: `make loadtest-proxy` writes one into benchmarks/results/.\n"
        )


def test_every_committed_result_renders():
    ext = _ext()
    folder = ROOT / "benchmarks" / "results"
    found = ext.records(folder)
    assert found, "benchmarks/results/ holds the committed results"
    assert len(found) == len(list(folder.glob("*.json")))  # every file is a record
    for path, record in found:
        assert path.name.startswith(record["bench"] + "-"), path
        assert "| figure | value |" in ext.render(folder, record["bench"])
