"""strandcast.daemon: a strandcastd child process on a free loopback port, for tests."""
import os
import re
import select
import signal
import subprocess
import time

from .codec import build_dir

# What tests/support/with_daemon.c starts the daemon with: a free port, the C backend, a small
# groom, one solver thread, no start-up speed check.
TEST_FLAGS = ("--port", "0", "--backend", "cpu", "--strands", "128", "--verts", "8", "--threads", "1",
              "--min-step-rate", "0")
_OPEN = re.compile(rb"open https?://(\[[^\]]*\]|[^:/\s]+):(\d+)/")


def daemon_path():
    """The strandcastd to run: $STRANDCASTD, else the build directory's."""
    return os.environ.get("STRANDCASTD") or str(build_dir() / "strandcastd")


class Daemon:
    """Starts exe (default daemon_path()) with TEST_FLAGS and then flags, and waits until it
    prints the address it serves (`port`, `url`); raises RuntimeError when it exits or says
    nothing within timeout seconds. stop() (or leaving `with`) sends SIGTERM and returns its
    exit status. Its stderr (the log) goes to this process's stderr. LD_PRELOAD is not passed
    on (the sanitizer tree preloads ASan into Python for the decoder library only)."""

    def __init__(self, *flags, exe=None, timeout=30.0):
        env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
        self.args = [exe or daemon_path(), *TEST_FLAGS, *flags]
        self.proc = subprocess.Popen(self.args, stdout=subprocess.PIPE, env=env)
        self.port = self._wait_port(timeout)
        self.url = f"ws://127.0.0.1:{self.port}/"

    def _wait_port(self, timeout):
        out = b""
        end = time.monotonic() + timeout
        fd = self.proc.stdout.fileno()
        while time.monotonic() < end:
            ready, _, _ = select.select([fd], [], [], 0.05)
            if not ready:
                continue
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            out += chunk
            m = _OPEN.search(out)
            if m:
                return int(m.group(2))
        self.stop(signal.SIGKILL)
        raise RuntimeError(f"{' '.join(self.args)} did not start (exit {self.proc.returncode}): {out!r}")

    def stop(self, sig=signal.SIGTERM, timeout=15.0):
        """Sends sig and returns the exit status (128 + signal when killed by one; SIGKILL after
        timeout seconds). Safe to call twice."""
        if self.proc.returncode is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
            self.proc.stdout.close()
        rc = self.proc.returncode
        return 128 - rc if rc < 0 else rc

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
