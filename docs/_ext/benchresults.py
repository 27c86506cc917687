"""The latest benchmark results as tables, made when the site is built.

In a Markdown page::

    ```{bench-results} bench
    ```

renders the latest record of the bench named `bench` in the results folder
(`bench_results_dir` in conf.py: the repository's benchmarks/results/,
written by `vibtrans bench --results-dir`, devtools/browserbench.py and
devtools/loadtest.py; vibtrans.tools.results) as a line on where and when
it was measured and a table of its figures.  A bench without a record, a
missing folder or an unreadable file gives a sentence, never a failed
build.  The rendering is Markdown text (`render`), parsed by the page's
own parser (MyST).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

# how each bench is run (said where it has no record yet)
COMMANDS = {
    "bench": "make bench",
    "bench-sweep": "vibtrans bench --sweep --results-dir benchmarks/results",
    "bench-export": "vibtrans bench --export --results-dir benchmarks/results",
    "bench-work-precision": "vibtrans bench --work-precision --results-dir benchmarks/results",
    "browserbench": "make bench-browser",
    "browserbench-memory-views": "python -m devtools.browserbench --memory-views 60",
    "latency": "python -m devtools.bench",
    "loadtest": "make loadtest-proxy",
    "sessioncpu": "python -m devtools.sessioncpu --sessions 10 --clicks 5",
}
_ESCAPE = "\\`*_[]<>|$~#!&{}"
_LIST_ITEMS = 8  # longer lists are shown by their length


def records(folder: str | Path) -> list[tuple[Path, dict]]:
    """Every readable record in `folder` as (path, record); files that are
    not JSON records are left out (a partial file is never there: the
    writers rename a finished file into place)."""
    out = []
    for path in sorted(Path(folder).glob("*.json")):
        try:
            record = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if (
            isinstance(record, dict)
            and isinstance(record.get("bench"), str)
            and isinstance(record.get("results"), dict)
        ):
            out.append((path, record))
    return out


def latest(folder: str | Path, bench: str) -> tuple[Path, dict] | None:
    """The newest record of `bench` in `folder` (by its finish time, then
    its file name), or None."""
    mine = [
        (r.get("finished_utc") or r.get("started_utc") or "", p.name, p, r)
        for p, r in records(folder)
        if r["bench"] == bench
    ]
    if not mine:
        return None
    *_, path, record = max(mine, key=lambda m: (m[0], m[1]))
    return path, record


def _escape(text: str) -> str:
    return "".join("\\" + c if c in _ESCAPE else c for c in text).replace("\n", " ")


def value_text(value) -> str:
    """A value as table text: numbers to 4 significant digits, long lists
    by their length, nothing as a dash."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.4g}" if math.isfinite(value) else "-"
    if isinstance(value, list):
        if len(value) > _LIST_ITEMS or any(isinstance(v, (list, dict)) for v in value):
            return f"{len(value)} values"
        return ", ".join(value_text(v) for v in value)
    return _escape(str(value))


def rows(results: dict, prefix: str = "") -> list[tuple[str, str]]:
    """The results as (key, value text) rows; nested dicts' keys joined by
    ' / ', in the record's order."""
    out = []
    for key, value in results.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            out += rows(value, f"{name} / ")
        else:
            out.append((name, value_text(value)))
    return out


def _where(path: Path, record: dict) -> str:
    m = record.get("machine") or {}
    parts = []
    if m.get("description"):
        parts.append(_escape(m["description"]))
    else:
        cpu = ", ".join(
            filter(
                None,
                [
                    m.get("cpu_model"),
                    f"{m['cores']} cores" if m.get("cores") else None,
                    f"{m['usable_cores']} usable"
                    if m.get("usable_cores") not in (None, m.get("cores"))
                    else None,
                    f"{m['memory_gb']:g} GB" if m.get("memory_gb") else None,
                ],
            )
        )
        if cpu:
            parts.append(_escape(cpu))
    start, end = m.get("load_average_start"), m.get("load_average_end")
    if start or end:
        parts.append("load average " + " -> ".join(value_text(x[0]) if x else "?" for x in (start, end)))
    versions = m.get("packages") or {}
    soft = [f"Python {m['python']}"] if m.get("python") else []
    soft += [f"{k} {versions[k]}" for k in ("vibtrans", "numpy", "numba", "panel", "bokeh") if k in versions]
    if soft:
        parts.append(_escape(", ".join(soft)))
    git = record.get("git")
    if git and git.get("commit"):
        parts.append(
            f"commit `{git['commit'][:10]}`" + (" with uncommitted changes" if git.get("dirty") else "")
        )
    when = record.get("finished_utc") or record.get("started_utc") or "?"
    text = f"Measured {_escape(when)}"
    if parts:
        text += " on " + "; ".join(parts)
    text += f". Command: `{record.get('command') or '?'}`. File: `{path.name}`."
    if record.get("note"):
        text += " " + _escape(record["note"])
    return text


def render(folder: str | Path, bench: str) -> str:
    """The latest record of `bench` in `folder` as Markdown: a paragraph on
    where, when and how it was measured, then a table of its figures (or a
    sentence saying how to make one)."""
    found = latest(folder, bench) if Path(folder).is_dir() else None
    if found is None:
        how = COMMANDS.get(bench, f"the {bench} bench")
        return f"No result of this bench yet: `{how}` writes one into benchmarks/results/.\n"
    path, record = found
    table = ["| figure | value |", "|---|---|"]
    table += [f"| `{k}` | {v} |" for k, v in rows(record["results"])]
    return _where(path, record) + "\n\n" + "\n".join(table) + "\n"


def setup(app):
    from sphinx.util.docutils import SphinxDirective

    class BenchResults(SphinxDirective):
        """```{bench-results} NAME```: the latest record of the bench NAME."""

        required_arguments = 1

        def run(self):
            folder = Path(self.env.srcdir) / self.config.bench_results_dir
            if folder.is_dir():
                for path, _ in records(folder):  # rebuilt when a record changes
                    self.env.note_dependency(str(path))
            return self.parse_text_to_nodes(render(folder, self.arguments[0]))

    app.add_config_value("bench_results_dir", "../benchmarks/results", "env")
    app.add_directive("bench-results", BenchResults)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
