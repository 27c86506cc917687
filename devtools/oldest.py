"""Checks for the oldest tier (`make test-oldest`): its venv runs the oldest
Python pyproject.toml declares, and every runtime dependency landed at
exactly its declared lower bound (not a version the resolver stepped to).

    python devtools/oldest.py --check-python
    python devtools/oldest.py --check-installed CONSTRAINTS
"""

import argparse
import re
import sys
import tomllib
from pathlib import Path

PYPROJECT = Path(__file__).resolve().parent.parent / "pyproject.toml"


def project():
    return tomllib.loads(PYPROJECT.read_text())["project"]


def oldest_python(requires):
    """(3, 11) from '>=3.11' (the only form the project uses)."""
    m = re.fullmatch(r"\s*>=\s*(\d+)\.(\d+)\s*", requires)
    if m is None:
        raise SystemExit(f"requires-python {requires!r}: expected '>=X.Y'")
    return int(m[1]), int(m[2])


def lower_bounds():
    """{normalized name: lower bound} of the runtime dependencies whose markers
    hold here; every one must declare exactly one '>=' bound."""
    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    out = {}
    for text in project()["dependencies"]:
        req = Requirement(text)
        if req.marker is not None and not req.marker.evaluate():
            continue
        lows = [s.version for s in req.specifier if s.operator == ">="]
        if len(lows) != 1:
            raise SystemExit(f"dependency {text!r}: expected exactly one '>=' lower bound")
        out[canonicalize_name(req.name)] = lows[0]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check-python", action="store_true")
    ap.add_argument("--check-installed", metavar="CONSTRAINTS")
    args = ap.parse_args(argv)
    if args.check_python:
        want = oldest_python(project()["requires-python"])
        if sys.version_info[:2] != want:
            raise SystemExit(
                f"the oldest tier needs Python {want[0]}.{want[1]} (requires-python), "
                f"this is {sys.version.split()[0]}"
            )
        print(f"oldest tier: Python {sys.version.split()[0]}")
    if args.check_installed:
        from importlib.metadata import version

        from packaging.version import Version

        wrong = []
        for name, low in sorted(lower_bounds().items()):
            have = version(name)
            if Version(have) != Version(low):
                wrong.append(f"{name} {have} (declared lower bound {low})")
        if wrong:
            raise SystemExit("not at the declared lower bound: " + "; ".join(wrong))
        print(
            f"oldest tier: {len(lower_bounds())} runtime dependencies at their lower bounds "
            f"({Path(args.check_installed).name})"
        )


if __name__ == "__main__":
    main()
