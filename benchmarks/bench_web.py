"""Load time and edit latency of the web workbench (``multiloop serve``) in a real browser (plain script).

Run:  python benchmarks/bench_web.py [--runs N] [--quick] [--settle S] [--other MULTILOOP] [--mechanism NAME]
      python benchmarks/bench_web.py --edit-latency [--edits N] [--names NAME ...]
      python benchmarks/bench_web.py --server [--edits N] [--names NAME ...]

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

``--edit-latency`` serves the page once and, for each catalogue mechanism (or
``--names``), once its check is shown, drags one joint with the mouse ``--edits`` times
(8 moves of 2 px each, then the drop; the joint is the one whose ring lies farthest from
the others on the screen).  The page times itself (``performance.now``, EDIT_TIMER_JS):
each mouse move to the animation frame in which the drawing shows the joint moved
(*follow*, goal 50 ms: the moves past Bokeh's tap threshold, 5 px from the press, where the
pan starts; the moves within it wait for the pan to start, their slowest is printed
apart), and the drop to the frame in which the re-solved drawing is in
the readout (*drawing*) and to the frame in which the new check's report is in the page
(*check*, goal 300 ms).  It prints the median and the maximum per mechanism.

``--server`` measures the server's share of the same re-check without a browser (with the
second core of ``multiloop serve`` unless ``--one-core``): per
mechanism, ``--edits`` edits in a session (the handle the browser's drag takes, moved as
far as the drag moves it),
the edit's handler, the job (every driver's sweep, then the check) and the showing of
its results, in ms (median and maximum); ``--calls`` adds the Python calls of one more
edit's job (a count that the machine's speed does not change; with ``--one-core`` it is
the whole job's).
"""
from __future__ import annotations

import argparse
import json
import os
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


#: the page times each mouse move of a drag until the drawing's joints change (window.__mlFollow, ms)
#: and each drop until the readout has the re-solved drawing and the check's report is
#: back (window.__mlDrop: {ack, draw, check}, ms; ack: the readout changed (cleared, when
#: the new design comes before its motion); draw: new positions in it; check: the
#: check's report, not its busy line, in the page with them)
EDIT_TIMER_JS = """() => {
  window.__mlFollow = []; window.__mlFollowPre = []; window.__mlDrop = [];
  if (window.__mlEditTimer) { return; }
  window.__mlEditTimer = true;
  // the element SEL, looked for in the shadow root it was last found in (a Div's new text
  // replaces its element in the same root), else in every shadow root: a walk of them all
  // each frame took the page's main thread some 25 ms a drop, inside the time measured
  const roots = {};
  const find = (sel) => { const r = roots[sel]; const e = r && r.querySelector(sel); if (e && e.isConnected) { return e; }
    const walk = (root) => { const f = root.querySelector(sel); if (f) { return [f, root]; }
      for (const x of root.querySelectorAll('*')) { if (x.shadowRoot) { const g = walk(x.shadowRoot); if (g) { return g; } } }
      return null; };
    const g = walk(document); if (g) { roots[sel] = g[1]; return g[0]; } return null; };
  const joints = () => { const d = Bokeh.documents[0].get_model_by_name('ml-joints').data;
    return JSON.stringify([d.x, d.y]); };
  const frame = () => new Promise(res => requestAnimationFrame(() => res()));
  // the page's elements are looked for only in the frames within 100 ms of a change of the
  // document (a walk of every shadow root each frame took a core the server needs)
  let changed = performance.now();
  const doc = Bokeh.documents[0];
  if (doc.on_change) { doc.on_change(() => { changed = performance.now(); }, true); }
  else { changed = Infinity; }
  // a move within Bokeh's tap threshold of the press (UIGestures.move_threshold, 5 px) is not
  // a drag yet: the drawing can only follow from the move that starts the pan
  let down = null;
  document.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; }, true);
  document.addEventListener('pointermove', (e) => {
    if (!(e.buttons & 1)) { return; }
    const t0 = performance.now(), before = joints();
    const pre = down != null && Math.hypot(e.clientX - down[0], e.clientY - down[1]) <= 5;
    (async () => { while (performance.now() - t0 < 5000) { await frame();
      if (joints() != before) { (pre ? window.__mlFollowPre : window.__mlFollow).push(performance.now() - t0);
        return; } } })();
  }, true);
  document.addEventListener('pointerup', () => {
    const t0 = performance.now(), rec = {};
    const positions = () => { const r = find('#ml-positions'); return r && r.getAttribute('data-positions'); };
    const before = positions();
    (async () => {
      while (performance.now() - t0 < 600000) { await frame();
        if (rec.ack === undefined && performance.now() - t0 > 30000) { rec.error = 'no new design 30 s after the drop'; break; }
        if (performance.now() - changed > 100) { continue; }
        const pos = positions();
        if (rec.ack === undefined && pos !== before) { rec.ack = performance.now() - t0; }
        if (rec.draw === undefined && pos && pos !== before) { rec.draw = performance.now() - t0; }
        // the report (not the busy line) with the new drawing: an edit whose check did not
        // change (a tracer point moved) leaves the report's element as it was
        const status = find('#ml-check-status');
        if (rec.draw !== undefined && status && status.tagName === 'H3') { rec.check = performance.now() - t0; break; }
        const msg = find('#ml-message');
        if (msg && msg.hasAttribute('data-error')) { rec.error = msg.textContent; break; } }
      if (rec.check === undefined && rec.error === undefined) { rec.error = 'no new check 600 s after the drop'; }
      window.__mlDrop.push(rec); })();
  }, true); }"""

#: the name and screen position of the drag ring NAME, or (NAME null) of the ring farthest
#: from every other ring
FAR_HANDLE_JS = """([name]) => { const doc = Bokeh.documents[0];
  const src = doc.get_model_by_name('ml-handles'), fig = doc.get_model_by_name('ml-mechanism');
  const view = Bokeh.index.find_one(fig);
  view.el.scrollIntoView({block: 'center'});
  const r = view.canvas_view.el.getBoundingClientRect(), f = view.frame;
  const p = src.data.name.map((n, i) => [n, r.left + f.x_scale.compute(src.data.x[i]),
                                           r.top + f.y_scale.compute(src.data.y[i])]);
  const inside = p.filter(q => q[1] > r.left + f.bbox.left + 20 && q[1] < r.left + f.bbox.right - 20
                            && q[2] > r.top + f.bbox.top + 20 && q[2] < r.top + f.bbox.bottom - 20);
  if (name != null) { return p.find(q => q[0] == name); }
  let best = null, far = -1;
  for (const q of inside) {
    const d = Math.min(...p.filter(o => o !== q).map(o => Math.hypot(o[1] - q[1], o[2] - q[2])));
    if (d > far) { far = d; best = q; } }
  return best; }"""


def _serve(exe: str):
    """``multiloop serve`` on a free port: (the process, the page's address)."""
    srv = subprocess.Popen([exe, "serve", "--port", str(_free_port())], stdout=subprocess.PIPE,
                           stderr=subprocess.DEVNULL, text=True)
    url = re.search(r"http://\S+", srv.stdout.readline())
    if url is None:
        srv.terminate()
        raise SystemExit(f"bench_web: {exe} serve printed no address")
    return srv, url.group(0)


def _checked(page, name: str, timeout_ms: int) -> None:
    """Wait until the page shows ``name`` (the menu's entry or ``edited: name``) with
    its motion and its check's report."""
    page.wait_for_function("""([name]) => { const deep = (sel) => { const out = []; const walk = (root) => {
        root.querySelectorAll(sel).forEach(e => out.push(e));
        root.querySelectorAll('*').forEach(e => { if (e.shadowRoot) walk(e.shadowRoot); }); };
        walk(document); return out; };
      const r = deep('#ml-positions')[0];
      return r && r.getAttribute('data-positions') && r.getAttribute('data-mechanism').endsWith(name)
        && deep('#ml-check-json').length > 0; }""", arg=[name], timeout=timeout_ms)


def edit_latency_of(page, name: str, edits: int, timeout_ms: int) -> dict:
    """``edits`` drags of one joint of catalogue mechanism ``name`` (module docstring):
    the page's own timings (ms)."""
    page.locator(".ml-pick select").select_option(name)
    _checked(page, name, timeout_ms)
    page.evaluate(EDIT_TIMER_JS)
    joint = page.evaluate(FAR_HANDLE_JS, [None])[0]
    for k in range(edits):
        sign = 1 if k % 2 == 0 else -1
        _, sx, sy = page.evaluate(FAR_HANDLE_JS, [joint])      # the drawing is fitted to each design
        page.mouse.move(sx, sy)
        page.mouse.down()
        for i in range(1, 9):
            page.mouse.move(sx + sign * 2 * i, sy + sign * i)
        page.mouse.up()
        page.wait_for_function(f"() => window.__mlDrop.length > {k}", timeout=timeout_ms)
        error = page.evaluate(f"() => window.__mlDrop[{k}].error")
        if error:
            print(f"{name}: drag {k + 1} of {joint}: {error}", flush=True)
            break
        _checked(page, name, timeout_ms)
    return dict(joint=joint, follow=page.evaluate("() => window.__mlFollow"),
                follow_pre=page.evaluate("() => window.__mlFollowPre"),
                drop=page.evaluate("() => window.__mlDrop"))


def _stats(values) -> str:
    import statistics
    v = [x for x in values if x is not None]
    return f"{statistics.median(v):7.1f} {max(v):7.1f}" if v else "      -       -"


def edit_latency(browser, exe: str, names, edits: int, timeout_s: float, each: bool = False) -> None:
    """Print the edit latency table of every mechanism of ``names`` (module docstring);
    with ``each``, every drop's check latency in order too."""
    srv, url = _serve(exe)
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    try:
        page.goto(url)
        page.wait_for_selector("#ml-positions[data-index]", state="attached", timeout=60000)
        print(f"{'mechanism':24s} {'joint':8s} follow (ms) median max  n | before the pan, max  n | "
              "drawing (ms) median max | check (ms) median max")
        for name in names:
            r = edit_latency_of(page, name, edits, int(1000 * timeout_s))
            drops = r["drop"]
            pre = r["follow_pre"]
            checks = [d.get("check") for d in drops]
            every = " | each: " + ", ".join("-" if c is None else f"{c:.0f}" for c in checks) if each else ""
            print(f"{name:24s} {r['joint'][:8]:8s} {_stats(r['follow'])} {len(r['follow']):3d} | "
                  f"{max(pre) if pre else float('nan'):12.1f} {len(pre):3d} | "
                  f"{_stats([d.get('draw') for d in drops])} | {_stats(checks)}{every}", flush=True)
    finally:
        page.close()
        srv.terminate()
        srv.wait(timeout=20)
        srv.stdout.close()


def _far_handle(view) -> tuple[str, float]:
    """The handle the browser's drag takes (FAR_HANDLE_JS: of those 20 px or more inside
    the plot, the one farthest from its nearest neighbour; equal scales on both axes, so
    in data units too) and the data units of one pixel of the drawing (its plot area,
    about)."""
    import numpy as np
    d = view.handles.data
    P = np.column_stack([d["x"], d["y"]])
    gap = np.hypot(*(P[:, None, :] - P[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(gap, np.inf)
    xr, yr = view.fig.x_range, view.fig.y_range
    px = (xr.end - xr.start) / (view.fig.width - 60)
    m = 20 * px
    inside = ((P[:, 0] > xr.start + m) & (P[:, 0] < xr.end - m) & (P[:, 1] > yr.start + m) & (P[:, 1] < yr.end - m))
    return d["name"][int(np.argmax(np.where(inside, gap.min(axis=1), -1.0)))], px


def _job_calls(wb, joint, to) -> int:
    """Python calls (functions and builtins) of the job of one edit of ``wb``: a count
    that does not depend on the machine's speed (the child's share is not counted)."""
    import threading
    n = [0]

    def count(frame, event, arg):
        if event in ("call", "c_call"):
            n[0] += 1
    threading.setprofile(count)            # the job's thread starts inside the edit
    try:
        wb.editor.drag(joint, to)
    finally:
        threading.setprofile(None)
    wb.job.thread.join()
    return n[0]


def server_latency_of(name: str, edits: int, calls: bool = False) -> dict:
    """``edits`` edits of catalogue mechanism ``name`` in a session without a browser (a
    :class:`~multiloop.web.app.Workbench` in a Bokeh document, as a page's): the handle
    the browser's drag takes moved as the drag moves it (16 px right and 8 px down, then
    back); seconds of the edit's handler, of the job (the sweeps, then the check) and of
    showing its results (the session's poll)."""
    from bokeh.document import Document

    from multiloop.web.app import Workbench
    wb = Workbench(requested=name)
    Document().add_root(wb.panel)

    def settle():
        while wb.job is not None:
            wb.job.thread.join()
            wb.poll()
    try:
        settle()
        joint, px = _far_handle(wb.view)
        out = dict(handler=[], job=[], show=[])
        for k in range(edits):
            d = wb.view.handles.data
            i = d["name"].index(joint)
            sign = 1 if k % 2 == 0 else -1
            t0 = time.perf_counter()
            wb.editor.drag(joint, (d["x"][i] + sign * 16 * px, d["y"][i] - sign * 8 * px))
            t1 = time.perf_counter()
            wb.job.thread.join()
            t2 = time.perf_counter()
            settle()
            t3 = time.perf_counter()
            for key, v in zip(out, (t1 - t0, t2 - t1, t3 - t2)):
                out[key].append(1000 * v)
        if calls:
            d = wb.view.handles.data
            i = d["name"].index(joint)
            out["calls"] = _job_calls(wb, joint, (d["x"][i] + 16 * px, d["y"][i] - 8 * px))
            settle()
        return out
    finally:
        wb.close()


def server_latency(names, edits: int, one_core: bool = False, calls: bool = False) -> None:
    """Print the server's share of a re-check per mechanism (:func:`server_latency_of`),
    with the second core of ``multiloop serve`` (:mod:`multiloop.web.second_core`) unless
    ``one_core``; with ``calls``, the Python calls of one more edit's job too."""
    ready = False
    if not one_core:
        from multiloop.web.second_core import SECOND_CORE
        SECOND_CORE.start()
        ready = SECOND_CORE.ready.wait(120)
    print(f"second core: {'on' if ready else 'off'}")
    print(f"{'mechanism':24s} handler (ms) median max | job: sweeps + check (ms) median max | "
          "show (ms) median max | total median")
    for name in names:
        r = server_latency_of(name, edits, calls)
        total = [a + b + c for a, b, c in zip(r["handler"], r["job"], r["show"])]
        print(f"{name:24s} {_stats(r['handler'])} | {_stats(r['job'])} | {_stats(r['show'])} | "
              f"{sorted(total)[len(total) // 2]:7.1f}" + (f" | calls {r['calls']}" if calls else ""), flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=4, help="page loads per executable (default 4)")
    ap.add_argument("--quick", action="store_true", help="2 page loads per executable")
    ap.add_argument("--settle", type=float, default=3.0, help="seconds the browser runs before serve starts")
    ap.add_argument("--other", help="a second multiloop executable to alternate with (e.g. a previous release)")
    ap.add_argument("--exe", help="the multiloop executable measured (default: the one beside this Python)")
    ap.add_argument("--mechanism", help="the FILE or catalogue name to open (default: the page's first)")
    ap.add_argument("--edit-latency", action="store_true",
                    help="time drags and the re-check after each drop, per catalogue mechanism")
    ap.add_argument("--edits", type=int, default=3, help="drags per mechanism (--edit-latency; default 3)")
    ap.add_argument("--one-core", action="store_true", help="--server without the second core")
    ap.add_argument("--each", action="store_true", help="--edit-latency: every drop's check latency too")
    ap.add_argument("--calls", action="store_true",
                    help="--server: the Python calls of one more edit's job (a count, not a time)")
    ap.add_argument("--names", nargs="*", help="the catalogue mechanisms of --edit-latency (default: all)")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds to wait for one re-check")
    ap.add_argument("--server", action="store_true",
                    help="the server's share of each re-check (no browser): handler, job, show, per mechanism")
    args = ap.parse_args(argv)
    if args.server:
        import warnings

        from multiloop.web.app import catalogue_names
        warnings.simplefilter("ignore")
        print(f"python {sys.version.split()[0]}; load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
        server_latency(args.names or catalogue_names(), args.edits, args.one_core, args.calls)
        print(f"load average at the end {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
        return 0
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
    ours = args.exe or str(Path(sys.executable).with_name("multiloop"))
    exes = [("this", ours)] + ([("other", args.other)] if args.other else [])
    if args.edit_latency:
        from multiloop.web.app import catalogue_names
        print(f"python {sys.version.split()[0]}; chromium {chromium}; {ours}; load average "
              f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}")
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox", "--disable-gpu"])
            for label, exe in exes:
                print(f"{label}: {exe}")
                edit_latency(browser, exe, args.names or catalogue_names(), args.edits, args.timeout, args.each)
            browser.close()
        print(f"load average at the end {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
        return 0
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
