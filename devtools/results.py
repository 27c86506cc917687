"""The development benches' runs as data: each writes its figures, the
machine and the git commit as one JSON file into benchmarks/results/ (or
--results-dir; vibtrans.tools.results), which the documentation renders
(docs/reference/benchmarks.md)."""

import sys
from pathlib import Path

from vibtrans.tools import results

RESULTS_DIR = Path(__file__).resolve().parent.parent / "benchmarks" / "results"
begin = results.begin


def add_option(ap):
    """--results-dir on an argparse parser (default: the checkout's
    benchmarks/results; an empty value writes nothing)."""
    ap.add_argument(
        "--results-dir",
        default=str(RESULTS_DIR),
        metavar="DIR",
        help="write the run as JSON (figures, machine, load, git commit) into "
        "DIR, named by the bench and its UTC start (default: "
        "benchmarks/results; '' for none)",
    )


def save(bench, out, begun, folder, command, note=None):
    """Write `out` as bench's record into `folder` (nothing if it is empty);
    says where on stderr.  Returns the path or None."""
    if not folder:
        return None
    record = results.result_record(bench, out, begun, command=command, note=note)
    path = results.write_result(record, folder=folder)
    print(f"results: {path}", file=sys.stderr)
    return path
