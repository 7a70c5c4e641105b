"""Running master.js (a VDA 5050 master written with vda-5050-lib) from a test: Node.js and the library,
installed with ``npm ci`` from the pinned package-lock.json into pytest's cache on first use (a clean
clone has no node_modules), then the script against a broker, its JSON lines parsed.

Where Node.js or npm is missing the tests that need them are skipped with the reason, except in CI (the
``CI`` environment variable, as ``.ci/run`` sets it, which installs both), where they fail.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from tests.transports.mqtt.mosquitto import in_ci

HERE = Path(__file__).parent
PINNED = ("package.json", "package-lock.json")


def unavailable() -> str | None:
    """Why master.js cannot run here, or None."""
    missing = [tool for tool in ("node", "npm") if shutil.which(tool) is None]
    if missing:
        return f"no {' or '.join(missing)} on this machine (apt-get install nodejs npm)"
    return None


def installed(request: pytest.FixtureRequest) -> Path:
    """A folder holding master.js and the pinned node_modules, in pytest's cache (a temporary folder with
    ``-p no:cacheprovider``); ``npm ci`` only when the lock file changed."""
    reason = unavailable()
    if reason is not None:
        if in_ci():
            pytest.fail(f"CI runs the third-party master (issue 31), but {reason}")
        pytest.skip(f"the third-party master needs Node.js: {reason}")
    digest = hashlib.sha256(b"".join((HERE / name).read_bytes() for name in PINNED)).hexdigest()[:16]
    cache: pytest.Cache | None = getattr(request.config, "cache", None)
    name = f"vda-5050-lib-{digest}"
    folder = cache.mkdir(name) if cache is not None else request.getfixturevalue("tmp_path_factory").mktemp(name)
    if not (folder / "node_modules" / "vda-5050-lib" / "package.json").exists():
        for name in PINNED:
            shutil.copyfile(HERE / name, folder / name)
        done = subprocess.run(["npm", "ci", "--no-audit", "--no-fund", "--loglevel=error"], cwd=folder,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, f"npm ci failed:\n{done.stdout}\n{done.stderr}"
    shutil.copyfile(HERE / "master.js", folder / "master.js")  # resolves the library from node_modules beside it
    return folder


@dataclass
class Outcome:
    returncode: int
    lines: list[dict[str, Any]]
    stderr: str

    def of(self, event: str, **match: Any) -> list[dict[str, Any]]:
        return [line for line in self.lines if line["event"] == event
                and all(line.get(key) == value for key, value in match.items())]

    @property
    def states(self) -> list[dict[str, Any]]:
        return self.of("state")

    def report(self) -> str:
        """What a failing assertion shows: the lines without the raw states, and stderr."""
        shown = [json.dumps({k: v for k, v in line.items() if k != "raw"}) for line in self.lines]
        return "\n".join(shown) + f"\n--- stderr ---\n{self.stderr[-4000:]}"


def run_master(folder: Path, broker_url: str, manufacturer: str, serial: str, *, map_id: str,
               leg: float = 2.0, virtual_agv: bool = False, step_timeout: float = 60.0) -> Outcome:
    args = ["node", str(folder / "master.js"), "--broker", broker_url, "--manufacturer", manufacturer,
            "--serial", serial, "--map", map_id, "--leg", str(leg)]
    if virtual_agv:
        args.append("--virtual-agv")
    env = {**os.environ, "STEP_TIMEOUT_S": str(step_timeout)}
    done = subprocess.run(args, capture_output=True, text=True, timeout=10 * step_timeout, env=env)
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    return Outcome(done.returncode, lines, done.stderr)
