"""The development benches' runs as records (vibtrans.tools.results): their
figures, the machine and the git commit as one JSON file in
benchmarks/results/, which the documentation renders."""

import argparse
import sys
from pathlib import Path

from vibtrans.tools import results

RESULTS_DIR = Path(__file__).resolve().parent.parent / "benchmarks" / "results"
begin = results.begin


def add_option(ap):
    ap.add_argument(
        "--results-dir",
        default=str(RESULTS_DIR),
        metavar="DIR",
        help="write the run as JSON into DIR (default: benchmarks/results; '' for none)",
    )


def save(bench, out, begun, folder, command):
    """Write `out` as bench's record into `folder` (nothing if it is empty)."""
    if folder:
        path = results.write_result(results.result_record(bench, out, begun, command=command), folder=folder)
        print(f"results: {path}", file=sys.stderr)


def show(out, width=26, digits=3):
    """The figures, one a line (error samples one each)."""
    for k, v in out.items():
        for x in v if k == "error_samples" else [v]:
            print(f"{k:>{width}}: {x:.{digits}f}" if isinstance(x, float) else f"{k:>{width}}: {x}")


def bounded(kind, lo, hi):
    """An argparse type: a `kind` in [lo, hi] (argparse's error, naming the option, otherwise)."""

    def parse(text):
        value = kind(text)
        if not lo <= value <= hi:  # NaN too
            raise argparse.ArgumentTypeError(f"must be in [{lo}, {hi}], got {value}")
        return value

    parse.__name__ = kind.__name__  # argparse's "invalid int value"
    return parse
