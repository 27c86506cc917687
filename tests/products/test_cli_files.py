"""File problems at the command line: an --out (or
--plot) into a missing folder, an unwritable place, a path that is a
folder, or a full disk is one line on stderr naming the path, exit status
2, and no partial file left (outputs are written to a temporary file
beside the target and renamed over it at the end: vibtrans/maps/outfiles.py)."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from budget import budget

from vibtrans.cli import main

SIM = ["simulate", "--amplitude", "0.5", "--mass", "1", "--periods", "2", "--tau", "0.5", "--twin", "never"]

# (command line with OUT for the output, what the output is)
COMMANDS = {
    "simulate": ([*SIM, "--out", "OUT/run.nc"], "file"),
    "export heatmap": (["export", "heatmap", "--out", "OUT/map.png"], "file"),
    "export html": (["export", "vertical", "--out", "OUT/vertical.html"], "file"),
    "threshold sweep": (
        [
            "threshold",
            "--sweep",
            "--log-mass=0:0:1",
            "--periods",
            "4",
            "--tau",
            "1",
            "--workers",
            "1",
            "--out",
            "OUT/vertical.nc",
        ],
        "file",
    ),
    "bench plot": (["bench", "--work-precision", "--quick", "--plot", "OUT/wp.png"], "file"),
    "sweep": (
        [
            "sweep",
            "--log-amplitude",
            "0:0:1",
            "--log-mass=0:0:1",
            "--periods",
            "2",
            "--tau",
            "0.5",
            "--workers",
            "1",
            "--out",
            "OUT/map.zarr",
        ],
        "folder",
    ),
    "export paper": (["export", "paper", "--periods", "2", "--out", "OUT/paper"], "folder"),
}


def _argv(name, out_dir):
    argv, _ = COMMANDS[name]
    return [a.replace("OUT", str(out_dir)) for a in argv]


def _target(name, out_dir):
    return Path(next(a for a in _argv(name, out_dir) if a.startswith(str(out_dir))))


def _error_line(err, argv, path):
    """The one line of the refusal (progress bars of the run before it aside)."""
    lines = [
        ln
        for ln in err.strip().splitlines()
        if ln.strip() and not ln.lstrip("\r").startswith(("threshold runs", "simulate", "paper figures"))
    ]
    assert len(lines) == 1, err[-3000:]
    assert lines[0].startswith(f"vibtrans {argv[0]}: error:"), lines[0]
    assert str(path) in lines[0], lines[0]
    return lines[0]


def _refused(capsys, argv, path):
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    return _error_line(err, argv, path)


def _no_files(folder, before=()):
    left = sorted(
        str(p.relative_to(folder))
        for p in Path(folder).rglob("*")
        if str(p.relative_to(folder)) not in before
    )
    assert not left, left


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_missing_folder(name, tmp_path, capsys):
    missing = tmp_path / "no" / "such"
    line = _refused(capsys, _argv(name, missing), _target(name, missing).parent)
    assert "no such folder" in line, line
    assert not (tmp_path / "no").exists()


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_unwritable_folder(name, tmp_path, capsys):
    if os.geteuid() == 0:
        # root writes through permission bits: sysfs refuses new files to anyone
        folder = Path("/sys")
    else:
        folder = tmp_path / "locked"
        folder.mkdir()
        folder.chmod(0o500)
    try:
        line = _refused(capsys, _argv(name, folder), folder)
        assert "cannot write in the folder" in line, line
        assert not _target(name, folder).exists()
    finally:
        if folder != Path("/sys"):
            folder.chmod(0o700)
    if folder != Path("/sys"):
        _no_files(folder)


@pytest.mark.parametrize("name", sorted(n for n, (_, kind) in COMMANDS.items() if kind == "file"))
def test_a_file_path_that_is_a_folder(name, tmp_path, capsys):
    target = _target(name, tmp_path)
    target.mkdir()
    line = _refused(capsys, _argv(name, tmp_path), target)
    assert "is a folder" in line, line
    assert target.is_dir() and not any(target.iterdir())


@pytest.mark.parametrize("name", sorted(n for n, (_, kind) in COMMANDS.items() if kind == "folder"))
def test_a_folder_path_that_is_a_file(name, tmp_path, capsys):
    target = _target(name, tmp_path)
    target.write_text("mine")
    line = _refused(capsys, _argv(name, tmp_path), target)
    assert "not a folder" in line, line
    assert target.read_text() == "mine"


# ------------------------------------------------------------------ disk full
# A process whose files may not grow past LIMIT bytes (RLIMIT_FSIZE, its
# signal ignored: writes fail with EFBIG) meets what a full disk does to a
# writer, on any machine; a small tmpfs (where the test may mount one) is
# the real thing (ENOSPC).
LIMIT = 2048
LIMITED = textwrap.dedent("""\
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit}))
    from vibtrans.cli import main
    sys.exit(main(sys.argv[1:]))
    """)


def _limited(argv, limit=LIMIT):
    return subprocess.run(
        [sys.executable, "-c", LIMITED.format(limit=limit), *argv],
        capture_output=True,
        text=True,
        timeout=budget(600),
    )


def _one_line(r, argv, path):
    assert r.returncode == 2, r.stderr[-3000:]
    return _error_line(r.stderr, argv, path)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["simulate", "export heatmap", "export html", "threshold sweep"])
def test_a_full_disk_leaves_no_partial_file_and_keeps_the_old_one(name, tmp_path):
    argv = _argv(name, tmp_path)
    target = _target(name, tmp_path)
    target.write_bytes(b"the previous result")
    r = _limited(argv)
    line = _one_line(r, argv, target)
    assert "cannot write" in line, line
    assert target.read_bytes() == b"the previous result"  # not truncated or replaced
    _no_files(tmp_path, before={target.name})


@pytest.fixture
def small_tmpfs(tmp_path):
    mnt = tmp_path / "small"
    mnt.mkdir()
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True, text=True
    )
    if r.returncode != 0:
        pytest.skip(
            f"cannot mount a small tmpfs here ({r.stderr.strip()}); "
            f"the file-size-limit tests stand in for a full disk"
        )
    try:
        yield mnt
    finally:
        # lazily: a writer that failed may still hold its file (HDF5 does)
        subprocess.run(["umount", "-l", str(mnt)], check=False)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["simulate", "export heatmap", "sweep"])
def test_a_really_full_disk(name, small_tmpfs, capsys):
    argv = [*_argv(name, small_tmpfs)]
    if name == "sweep":  # enough points that the store outgrows 64 KiB
        argv[argv.index("--log-mass=0:0:1")] = "--log-mass=-1:1:0.005"
    target = _target(name, small_tmpfs)
    (small_tmpfs / "filler").write_bytes(b"\0" * (60 * 1024))
    line = _refused(capsys, argv, target)
    assert "cannot write" in line and "space" in line, line
    _no_files(small_tmpfs, before={"filler"})


def test_the_help_names_every_subcommand(capsys):
    # the summary line is made from the subcommands (it once left out orbit)
    import re

    with pytest.raises(SystemExit):
        main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    commands = re.search(r"\{([a-z,]+)\}", text).group(1).split(",")
    assert "orbit" in commands
    summary = re.search(r"Command line: vibtrans ([a-z| ]+)\.", text).group(1)
    assert summary.split(" | ") == commands


def test_a_decided_run_that_goes_to_its_end_prints_its_summary(capsys):
    # paper point 4 still accelerates at 100 periods: the decided stop runs
    # it to the end, which has no asymptotic rate (null, not a crash)
    import json

    assert (
        main(
            [
                "simulate",
                "--log-amplitude",
                "2.5",
                "--log-mass",
                "0",
                "--periods",
                "100",
                "--stop",
                "decided",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["stop_reason"] == "ran-to-end" and out["asymptotic_drift_velocity"] is None
