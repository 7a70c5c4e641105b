"""The live page (docs/contract.md §13, issue 33 item 3): ``vcran live``/``vcran manage ... --view PORT`` serve the page
on 127.0.0.1 and it follows the run as its folder grows, the slider still able to look back."""

from __future__ import annotations

import shutil
import socket

import httpx
import pytest

from tests.conftest import ROOT
from tests.transports.test_live import broker_process, free_port, stop, vcran, wait_until  # noqa: F401
from tests.view.browser import open_page
from tests.view.runs import bundled, still_running
from vcran.cli import main
from vcran.view.live import LiveView, live_folder

DEMO = ROOT / "scenarios" / "demo.toml"


@pytest.fixture(scope="module")
def warehouse(tmp_path_factory):
    return bundled("warehouse", tmp_path_factory.mktemp("live") / "warehouse")


def grow(source, out, cut: int) -> None:
    """The run folder ``out`` while it runs, written up to ``cut`` lines of its trace and events."""
    running = out.with_name(out.name + ".incomplete")
    staged = still_running(source, out.with_name("staged.incomplete"), cut)
    shutil.rmtree(running, ignore_errors=True)
    staged.rename(running)


def test_the_live_page_follows_the_growing_run_and_can_look_back(browser, warehouse, tmp_path):
    out = tmp_path / "run"
    grow(warehouse, out, 200)
    with LiveView(live_folder(out), free_port(), interval=0.05) as view:
        page = open_page(browser, view.url)
        first = page.js("vcranView.end()")
        assert page.js("vcranView.time()") == 0.0
        page.js("vcranView.seek(vcranView.end())")  # at the end: it follows
        assert page.page.locator("#live").inner_text().startswith("live")
        grow(warehouse, out, 900)
        page.page.wait_for_function(f"() => vcranView.end() > {first}")
        assert page.js("vcranView.time()") == page.js("vcranView.end()")
        page.js("vcranView.seek(10)")  # looking back: it stays there
        shutil.rmtree(out.with_name("run.incomplete"))
        shutil.copytree(warehouse, out)  # the run ended: the folder renamed, complete
        page.page.wait_for_function("() => vcranView.app.data.complete")
        assert page.js("vcranView.end()") == pytest.approx(3362.0)  # summary.json's sim_time
        assert page.js("vcranView.time()") == 10.0
        assert page.page.locator("#live").inner_text() == "ended at 56:02.0"
        assert page.problems == []
        assert all(url.startswith(view.url) for url in page.requests) and view.url + "events" in page.requests
        page.page.close()


def test_vcran_live_serves_the_page_and_it_advances(browser, broker_process, tmp_path):  # noqa: F811
    """End to end, as README's live mode: the broker, vcran live --view PORT, the script sent; the page
    served on 127.0.0.1:PORT advances with the run."""
    url = broker_process
    assert main(["orion", "init", str(DEMO), "--orion", url]) == 0
    port = free_port()
    live = vcran("live", str(DEMO), "--orion", url, "--out", str(tmp_path / "live"), "--factor", "20",
                 "--view", str(port))
    try:
        assert live.stdout.readline().startswith("live: ")
        assert live.stdout.readline() == f"view: http://127.0.0.1:{port}/ (follows the run as it goes)\n"
        assert wait_until(lambda: _ok(f"http://127.0.0.1:{port}/"), 20)
        page = open_page(browser, f"http://127.0.0.1:{port}/")
        start = page.js("vcranView.end()")
        sender = vcran("send", str(DEMO), "--orion", url, "--factor", "20", "--quiet")
        assert sender.wait(timeout=30) == 0, sender.stderr.read()
        page.page.wait_for_function(f"() => vcranView.end() > {start} + 10", timeout=30000)
        page.page.wait_for_function("() => vcranView.status('robot_1').taskLabel !== ''", timeout=30000)
        assert page.problems == []
        page.page.close()
    finally:
        stop(live)
    assert live.returncode == 0
    assert (tmp_path / "live" / "summary.json").is_file()


def _ok(url: str) -> bool:
    try:
        return httpx.get(url, timeout=2).status_code == 200
    except httpx.HTTPError:
        return False


@pytest.mark.parametrize("command", ["live", "manage"])
def test_view_needs_out_and_a_free_port(tmp_path, capsys, command):
    """--view refused before anything runs: without --out (manage's is optional), on a port in use."""
    scenario = str(ROOT / "scenarios" / ("warehouse.toml" if command == "manage" else "demo.toml"))
    orion = "http://127.0.0.1:9"  # never contacted: the refusals come first
    if command == "manage":
        assert main(["manage", scenario, "--orion", orion, "--view", "8999"]) == 2
        err = capsys.readouterr().err
        assert err == "vcran manage: --view shows the run folder as it is written: give --out\n"
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = tmp_path / "out"
        assert main([command, scenario, "--orion", orion, "--out", str(out), "--view", str(port), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vcran {command}: cannot serve the view on 127.0.0.1:{port}: ") and err.count("\n") == 1
    assert not out.exists() and not out.with_name("out.incomplete").exists()
