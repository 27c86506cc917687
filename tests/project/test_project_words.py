"""The project speaks of the product only: code, tests and docs do not
narrate how they were made (issue numbers, work sessions, dates, the
machine they were written on).  History lives in git and CHANGELOG.md,
measurements in benchmarks/results/."""

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# where dates belong: the changelog and the benchmark results
DATED = ("CHANGELOG.md", "benchmarks/results/")
# "the first session" and "a second session" are the product's (a browser's
# sessions on the server), so the ordinals of a work session start at third
ORDINAL = (
    "third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth|"
    "thirteenth|fourteenth|fifteenth|sixteenth|seventeenth|eighteenth|nineteenth|"
    "twentieth|\\d+(?:st|nd|rd|th)|[A-Z]\\d+"
)
NARRATION = {
    # also with a hyphen, a hash or an underscore before the number (a
    # test's name too)
    "an issue number": re.compile(r"(?<![a-z])issues?[\s_#-]*\d+", re.I),
    "a work session": re.compile(
        rf"\b(?:{ORDINAL})\s+session\b|\bwork(?:ing)?\s+sessions?\b"
        r"|\bsession\s+[A-Z]?\d+\b",
        re.I,
    ),
    # a date joined to its time ("2031-01-02T03:04:05Z") is a record's
    # timestamp, data a test or a results file reads, not prose
    "a date": re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b"),
    "a machine's path": re.compile(r"(?<![\w.])/(?:work|root|home/\w+)/"),
    "a helper's name": re.compile(r"\b(?:[Hh]elper[- ]?\d+|H\d)\b"),
}
# the words themselves, in this file
SELF = "tests/project/test_project_words.py"


def _tracked():
    out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    return [f for f in out.stdout.decode().split("\0") if f]


def _text_files():
    for name in _tracked():
        if name == SELF or name.startswith(("assets/", "docs/_static/")):
            continue
        path = ROOT / name
        if (
            path.suffix
            not in {
                ".py",
                ".md",
                ".toml",
                ".cfg",
                ".txt",
                ".sh",
                ".yml",
                ".yaml",
                ".ipynb",
                ".rst",
                ".html",
                ".css",
                ".js",
                "",
            }
            or not path.is_file()
        ):
            continue
        try:
            yield name, path.read_text()
        except UnicodeDecodeError:
            continue


def test_nothing_narrates_how_it_was_made():
    found = []
    for name, text in _text_files():
        for number, line in enumerate(text.splitlines(), 1):
            for what, pattern in NARRATION.items():
                if what == "a date" and name.startswith(DATED):
                    continue
                if pattern.search(line):
                    found.append(f"{name}:{number}: {what}: {line.strip()[:100]}")
    assert not found, "\n".join(found[:60]) + f"\n({len(found)} in all)"


def _said(sample):
    """A sample of narration as the check must find it: written here with a
    '|' inside its telling word, so that this file does not itself read as
    narration to a reader or a scanner of the tree's text."""
    return sample.replace("|", "")


def test_the_check_finds_each_kind():
    lines = {
        "an issue number": [
            "fixed in iss|ue 34",
            "iss|ues 14 and 32",
            "Iss|ue #32",
            "the iss|ue-16 figures",
            "def test_iss|ue_14_runs():",
        ],
        "a work session": [
            "the twentieth sess|ion",
            "the D3 sess|ion",
            "in sess|ion 12",
            "a work sess|ion",
        ],
        "a date": ["measured 20|26-11-24", "until 20|26-11-27 05:00 UTC"],
        "a machine's path": ["see /wo|rk/main/x.py", "in /ro|ot/.cache", "/ho|me/ann/x"],
        "a helper's name": ["H|2 found it", "help|er-3's change", "Help|er 3 said"],
    }
    for what, examples in lines.items():
        for line in examples:
            assert "|" in line and NARRATION[what].search(_said(line)), (what, line)
    for product in (
        "one session's page",
        "the last session closed",
        "sessions x clicks",
        "before the first session",
        "a second session opens",
        "--sessions 30",
        "an issue tracker",
        "a tissue 3 um thick",
        "np.float64",
        "H2O",
        "help helpers",
        "~/.cache/vibtrans",
        "tests/work/x",
        "log10 A* = 2.5",
        "2031-01-02T03:04:05Z",
        "1970-01-01 00:00:00,000",
    ):
        assert not any(p.search(product) for p in NARRATION.values()), product
