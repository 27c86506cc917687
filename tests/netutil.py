"""Network helpers shared by the tests that start a server: a free port and
`vibtrans serve` as a process (the served-explorer fixture in conftest.py,
and the installed wheel's server in test_wheel.py)."""

import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from budget import budget

READY_LINE = "kernels ready"  # app/server/warmup.py, once the warm-up is done


def free_port():
    """A TCP port on 127.0.0.1 that is free now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Served:
    """`vibtrans serve` on a free port, its stdout and stderr in a log file.

    command: how to run the command line (default: this interpreter's
    `-m vibtrans.cli`, a real command line, so the server re-executes
    itself on the C allocator as when started from a shell)."""

    def __init__(self, command=None, env=None, cwd=None, args=()):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}/"
        self.log = tempfile.NamedTemporaryFile(prefix="vibtrans-serve-", suffix=".log", delete=False)
        command = list(command or [sys.executable, "-m", "vibtrans.cli"])
        self.proc = subprocess.Popen(
            [*command, "serve", "--port", str(self.port), *args],
            cwd=cwd,
            env=env,
            stdout=self.log,
            stderr=subprocess.STDOUT,
        )
        self.started = time.perf_counter()
        self.first_page_s = None

    def text(self):
        return Path(self.log.name).read_text(errors="replace")

    def wait_page(self, timeout=None):
        """Wait until the explorer's page answers (200); returns the seconds
        from the start of the process.  A hang ends after `timeout` s
        (default: budget(300), scaled to the machine)."""
        timeout = budget(300) if timeout is None else timeout
        while True:
            try:
                with urllib.request.urlopen(self.url, timeout=budget(60)) as r:
                    if r.status == 200:
                        self.first_page_s = time.perf_counter() - self.started
                        return self.first_page_s
            except OSError:
                pass
            if self.proc.poll() is not None:
                raise RuntimeError(f"vibtrans serve exited ({self.proc.returncode}):\n{self.text()[-4000:]}")
            if time.perf_counter() - self.started > timeout:
                self.stop()
                raise RuntimeError(f"vibtrans serve: no page in {timeout:.0f} s:\n{self.text()[-4000:]}")
            time.sleep(0.2)

    def wait_kernels(self, timeout=None):
        """Wait until the server has compiled (or loaded) its kernels (its log
        says READY_LINE); a hang ends after `timeout` s (default: budget(600))."""
        timeout = budget(600) if timeout is None else timeout
        while READY_LINE not in self.text():
            if self.proc.poll() is not None:
                raise RuntimeError(f"vibtrans serve exited:\n{self.text()[-4000:]}")
            if time.perf_counter() - self.started > timeout:
                raise RuntimeError(
                    f"vibtrans serve: kernels not ready in {timeout:.0f} s:\n{self.text()[-4000:]}"
                )
            time.sleep(0.2)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(budget(15))
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self.log.close()
        try:
            os.unlink(self.log.name)
        except OSError:
            pass
