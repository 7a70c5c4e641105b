"""``vcran view`` at scale (docs/contract.md §13, issue 33 item 5): page size, build time, load time and scrub redraws.

For each fleet (``vcran gen --robots N --hours H --seed S``, run with its script): the wall time to write
the page and its size; then, in headless Chromium (the system's, as tests/view does), the time from
opening the page to its data decoded and first drawn, and the redraw time of scrubs measured in the
browser with ``performance.now()``: ``vcranView.seek(t)`` (the floor, the time strip and the panels
redrawn), and the same followed by a forced layout (the robot table's changed cells laid out), at
``--scrubs`` random instants and as a drag across the whole run in small steps, each instant the least
time of ``--repeat`` scrubs to it (the machine's other load only ever adds). The targets: a page of
at most 25 MB and a scrub within 50 ms for 100 robots over 8 hours.

    .venv/bin/python benchmarks/bench_view.py                       # 100 x 8 h and 1000 x 1 h
    .venv/bin/python benchmarks/bench_view.py --fleets 10x1 --keep /tmp/bench-view
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.view.browser import ARGS, chromium  # noqa: E402
from vcran.api import simulate  # noqa: E402
from vcran.io.gen import generate  # noqa: E402
from vcran.io.scenario_file import parse  # noqa: E402
from vcran.view import write_page  # noqa: E402


def fleet_run(robots: int, hours: float, seed: int, base: Path) -> Path:
    out = base / f"fleet-{robots}x{hours:g}h-s{seed}"
    if not (out / "summary.json").is_file():
        started = time.perf_counter()
        simulate(parse(tomllib.loads(generate(robots, hours, seed)), f"gen {robots}x{hours}"), out=out)
        print(f"  ran {robots} robots x {hours:g} h in {time.perf_counter() - started:.1f} s", file=sys.stderr)
    return out


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))]


def measure(browser, page_file: Path, scrubs: int, seed: int, repeat: int) -> dict[str, float]:
    page = browser.new_page(viewport={"width": 1400, "height": 800})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    started = time.perf_counter()
    page.goto(page_file.resolve().as_uri())
    page.evaluate("vcranView.ready")
    loaded = time.perf_counter() - started
    end = page.evaluate("vcranView.end()")
    rng = random.Random(seed)
    instants = [rng.uniform(0, end) for _ in range(scrubs)]
    drag = [end * k / scrubs for k in range(scrubs + 1)]
    timings = page.evaluate("""([instants, drag, repeat]) => {
        // each instant scrubbed to `repeat` times, from elsewhere each time; its least time counts (what the
        // page costs, without the pauses a shared machine's other load adds)
        const least = (f) => (t) => { let best = Infinity;
            for (let r = 0; r < repeat; r++) { vcranView.seek(0); void document.body.offsetHeight; best = Math.min(best, f(t)); }
            return best; };
        const seek = (t) => vcranView.seek(t);
        const laid = (t) => { const s = performance.now(); vcranView.seek(t); void document.body.offsetHeight;
                              return performance.now() - s; };
        return { random: instants.map(least(seek)), randomLaid: instants.map(least(laid)), drag: drag.map(least(seek)) };
    }""", [instants, drag, repeat])
    heap = page.evaluate("performance.memory ? performance.memory.usedJSHeapSize : 0")
    page.close()
    if errors:
        raise SystemExit(f"{page_file}: the page logged errors: {errors[:3]}")
    return {"load_s": loaded, "heap_mb": heap / 1e6,
            "seek_p50": statistics.median(timings["random"]), "seek_p95": percentile(timings["random"], 0.95),
            "seek_max": max(timings["random"]), "laid_p50": statistics.median(timings["randomLaid"]),
            "laid_p95": percentile(timings["randomLaid"], 0.95), "drag_p95": percentile(timings["drag"], 0.95)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fleets", default="100x8,1000x1", help="ROBOTSxHOURS,... (default: 100x8,1000x1)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--scrubs", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=3, help="scrubs to each instant; the least time counts (default 3)")
    parser.add_argument("--keep", type=Path, help="keep the runs and pages here (and reuse runs found there)")
    parser.add_argument("--reuse-pages", action="store_true", help="with --keep: open the pages found there as they are")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    base = args.keep or Path(tempfile.mkdtemp(prefix="bench-view-"))
    base.mkdir(parents=True, exist_ok=True)
    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium(), args=ARGS)
        for spec in args.fleets.split(","):
            robots, hours = spec.lower().split("x")
            run = fleet_run(int(robots), float(hours), args.seed, base)
            page_file, built = base / f"{run.name}.html", float("nan")
            if not (args.reuse_pages and page_file.is_file()):
                started = time.perf_counter()
                write_page(run, page_file)
                built = time.perf_counter() - started
            m = measure(browser, page_file, args.scrubs, args.seed, args.repeat)
            rows.append((spec, page_file.stat().st_size / 1e6, built, m))
        browser.close()
    print(f"\nload average {os.getloadavg()[0]:.2f}; scrubs: {args.scrubs} random instants and a drag of "
          f"{args.scrubs} steps, each the least of {args.repeat}; times in ms unless said\n")
    print("| fleet (robots x h) | page MB | write page s | open s | JS heap MB | seek p50 | seek p95 | seek max "
          "| seek + layout p50 | seek + layout p95 | drag p95 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for spec, size, built, m in rows:
        print(f"| {spec} | {size:.1f} | {built:.1f} | {m['load_s']:.2f} | {m['heap_mb']:.0f} | {m['seek_p50']:.1f} "
              f"| {m['seek_p95']:.1f} | {m['seek_max']:.1f} | {m['laid_p50']:.1f} | {m['laid_p95']:.1f} "
              f"| {m['drag_p95']:.1f} |")
    if args.keep is None:
        import shutil

        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
