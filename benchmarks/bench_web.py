"""Load time of the web workbench (``multiloop serve``) in a real browser (plain script).

Run:  python benchmarks/bench_web.py [--runs N] [--quick] [--settle S] [--other MULTILOOP] [--mechanism NAME]

Each run starts ``multiloop serve`` on a free port, opens the address it prints (with
its token) in Debian's chromium (driven by Playwright; its own browser download is not
used) and waits until the drawing can be moved (the readout ``#ml-positions[data-index]`` is in the page).  It
prints, in seconds from the start of ``serve``: the address printed, the page's HTML
received, the page's scripts run (``domInteractive``) and the page usable, plus the
bytes of script the page loaded.  The browser is started ``--settle`` seconds before
``serve`` (default 3: a user's browser is already running; 0 measures a browser that
starts at the same moment).  ``--other`` names a second ``multiloop`` executable (e.g.
a previous release in its own environment): the runs alternate between the two, and the
ratio of the mean load times is printed.  The goal is a page usable within 3 s.
Without Playwright or chromium (the ``[browser-test]`` extra, Debian's ``chromium``) it
says so and exits 0, so that ``multiloop bench`` goes on.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

#: the browser's navigation timing and the script bytes it loaded
TIMINGS_JS = """() => JSON.stringify({origin: performance.timeOrigin,
  interactive: performance.getEntriesByType('navigation')[0].domInteractive,
  scripts: performance.getEntriesByType('resource').filter(e => e.name.includes('.js'))
    .reduce((s, e) => s + e.transferSize, 0)})"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def load_once(browser, exe: str, settle: float, mechanism: str | None) -> dict:
    """One page load: seconds from ``serve``'s start to each stage."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    time.sleep(settle)
    port = _free_port()
    t0, wall0 = time.perf_counter(), time.time()
    srv = subprocess.Popen([exe, "serve", "--port", str(port), *([mechanism] if mechanism else [])],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        line = srv.stdout.readline()
        address = time.perf_counter() - t0
        url = re.search(r"http://\S+", line)       # with the page's token (a release before it had none)
        if url is None:
            raise SystemExit(f"bench_web: {exe} serve printed no address: {line!r}")
        page.goto(url.group(0), wait_until="commit")
        html = time.perf_counter() - t0
        page.wait_for_selector("#ml-positions[data-index]", state="attached", timeout=60000)
        usable = time.perf_counter() - t0
        t = json.loads(page.evaluate(TIMINGS_JS))
        scripts = t["origin"] / 1000 - wall0 + t["interactive"] / 1000
        return dict(address=address, html=html, scripts=scripts, usable=usable, script_bytes=t["scripts"])
    finally:
        page.close()
        srv.terminate()
        srv.wait(timeout=20)
        srv.stdout.close()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=4, help="page loads per executable (default 4)")
    ap.add_argument("--quick", action="store_true", help="2 page loads per executable")
    ap.add_argument("--settle", type=float, default=3.0, help="seconds the browser runs before serve starts")
    ap.add_argument("--other", help="a second multiloop executable to alternate with (e.g. a previous release)")
    ap.add_argument("--mechanism", help="the FILE or catalogue name to open (default: the page's first)")
    args = ap.parse_args(argv)
    runs = 2 if args.quick else args.runs
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        print("bench_web skipped: Playwright is not installed (pip install 'multiloop[browser-test]')")
        return 0
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("bench_web skipped: no chromium on the PATH (Debian: apt-get install chromium)")
        return 0
    ours = str(Path(sys.executable).with_name("multiloop"))
    exes = [("this", ours)] + ([("other", args.other)] if args.other else [])
    print(f"python {sys.version.split()[0]}; chromium {chromium}; settle {args.settle} s; {ours}"
          + (f" against {args.other}" if args.other else ""))
    usable: dict[str, list[float]] = {k: [] for k, _ in exes}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox", "--disable-gpu"])
        for run in range(1, runs + 1):
            for label, exe in (exes if run % 2 else exes[::-1]):
                r = load_once(browser, exe, args.settle, args.mechanism)
                usable[label].append(r["usable"])
                print(f"run {run} {label:5s}: address {r['address']:.2f}  html {r['html']:.2f}  "
                      f"scripts run {r['scripts']:.2f}  usable {r['usable']:.2f} s  "
                      f"({r['script_bytes'] / 1e6:.2f} MB of script)", flush=True)
        browser.close()
    mean = {k: sum(v) / len(v) for k, v in usable.items()}
    met = sum(u <= 3.0 for u in usable["this"])
    print(f"goal web page usable after serve starts: mean {mean['this']:.2f} s, max {max(usable['this']):.2f} s "
          f"(goal <= 3 s; {met} of {len(usable['this'])} runs) -> {'met' if met == len(usable['this']) else 'not met'}")
    if args.other:
        print(f"previous / this: {mean['other']:.2f} s / {mean['this']:.2f} s = {mean['other'] / mean['this']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
