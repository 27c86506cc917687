"""docs/getting-started.md as a new user follows it: every Python block
runs as written and says what the page says it prints, every command runs
(the long-running ones, `make serve` and `make test`, as their recipes:
`make -n`)."""

import re
import subprocess
import sys
from pathlib import Path

from budget import budget

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "getting-started.md"


def _blocks(kind):
    return re.findall(rf"```{kind}\n(.*?)```", PAGE.read_text(), flags=re.S)


def test_the_python_blocks_run_as_written():
    blocks = _blocks("python")
    assert blocks
    for code in blocks:
        r = subprocess.run(
            [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=budget(600)
        )
        assert r.returncode == 0, r.stderr[-3000:]
        # the page says the drift is negative and the particle hops
        drift = float(re.search(r"drift <v\*> = (\S+) a0 per period", r.stdout).group(1))
        assert drift < 0 and "jumping" in r.stdout and "against the wave" in r.stdout


def test_every_command_runs_as_written():
    commands = [line.strip() for block in _blocks("console") for line in block.splitlines() if line.strip()]
    assert "make serve" in commands and "make test" in commands
    venv_bin = Path(sys.executable).parent
    for command in commands:
        if command.startswith("make "):
            # a server and the whole suite: their recipes exist and parse
            r = subprocess.run(
                ["make", "-n", command.split()[1]],
                cwd=ROOT,
                capture_output=True,
                text=True,
                timeout=budget(60),
            )
        else:
            argv = command.split()
            argv[0] = str(venv_bin / Path(argv[0]).name)  # this checkout's venv
            r = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, timeout=budget(600))
        assert r.returncode == 0, (command, r.stdout[-2000:], r.stderr[-2000:])


def test_the_links_name_pages_that_exist():
    for target in re.findall(r"\]\(([^)#:]+)\)", PAGE.read_text()):
        assert (PAGE.parent / target).exists(), target
