"""A real Mosquitto on loopback for the MQTT edge's tests (docs/contract.md §11, issue 31 item 4): the system's broker
(Debian's ``mosquitto`` package), started on a free port with a minimal configuration bound to 127.0.0.1.

Where no Mosquitto is installed, the tests that need it are skipped with the reason, except in CI (the
``CI`` environment variable set, as ``.ci/run`` does), where a missing broker fails them: CI must install
it. ``VCRAN_MOSQUITTO`` names another Mosquitto binary.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
from pathlib import Path

from tests.view.browser import in_ci  # the house rule for CI, one definition

__all__ = ["Mosquitto", "free_port", "in_ci", "mosquitto", "unavailable"]


def mosquitto() -> str | None:
    found = os.environ.get("VCRAN_MOSQUITTO") or shutil.which("mosquitto")
    if found is None and os.access("/usr/sbin/mosquitto", os.X_OK):  # Debian's place, off a user's PATH
        found = "/usr/sbin/mosquitto"
    return found


def unavailable() -> str | None:
    """Why no broker test can run here, or None."""
    try:
        import paho.mqtt  # noqa: F401
    except ImportError:
        return "paho-mqtt is not installed (pip install -e '.[test]')"
    found = mosquitto()
    if found is None:
        return "no Mosquitto on this machine (apt-get install mosquitto, or set VCRAN_MOSQUITTO to its binary)"
    if not os.access(found, os.X_OK):
        return f"VCRAN_MOSQUITTO names {found}, which is no program"
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Mosquitto:
    """One broker process on ``port``; :meth:`stop` and :meth:`start` again keep the port (a restart)."""

    def __init__(self, folder: Path, port: int | None = None, *, anonymous: bool = True) -> None:
        self.port = port or free_port()
        self.url = f"mqtt://127.0.0.1:{self.port}"
        self.config = folder / "mosquitto.conf"
        self.log = folder / "mosquitto.log"
        # persistence false: a restart loses retained messages and sessions, the harsher case for the edge
        self.config.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous {str(anonymous).lower()}\n"
                               "persistence false\n"
                               "log_dest stderr\nlog_type error\nlog_type warning\n")
        self.process: subprocess.Popen[bytes] | None = None

    def start(self, timeout: float = 10.0) -> None:
        binary = mosquitto()
        assert binary is not None
        with self.log.open("ab") as log:
            self.process = subprocess.Popen([binary, "-c", str(self.config)], stdout=log, stderr=log,
                                            stdin=subprocess.DEVNULL)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"mosquitto exited with {self.process.returncode}: {self.log.read_text()[-2000:]}")
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.5):
                    return
            except OSError:
                time.sleep(0.02)
        self.stop()
        raise RuntimeError(f"mosquitto did not listen on port {self.port} within {timeout} s")

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.process = None
