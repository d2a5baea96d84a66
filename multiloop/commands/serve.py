"""``multiloop serve [FILE ...] [--port P] [--host H] [--open] [--atlas DB]``: the web workbench.

Serves a local page (a Bokeh server, the ``[web]`` extra) to open a mechanism, move it,
see its design check and structure, synthesise a path generator from a drawn or uploaded
target, and browse stored atlases (docs/web.md).  It binds 127.0.0.1 unless ``--host``
asks for another address (with a warning: the page has no login).  The files given are
read before serving, so a bad file is an error (exit 2) and nothing is served.  The
server writes no file; only the user's downloads leave it.
"""
from __future__ import annotations

import sys

from multiloop.topo.errors import InputError, explain

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument("files", nargs="*", metavar="FILE", help="mechanisms to open (.toml, .json, .pyslvs or catalogue names)")
    p.add_argument("--port", type=int, default=5006, help="port (default 5006; 0 picks a free one)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1; another one exposes the page to the network)")
    p.add_argument("--open", action="store_true", help="open the page in the default browser")
    p.add_argument("--atlas", action="append", default=[], metavar="DB",
                   help="an atlas file (SQLite, from 'multiloop atlas') to browse, read-only; repeatable")
    p.add_argument("--min-transmission", type=float, default=40.0, metavar="DEG",
                   help="the check's threshold (default 40, as 'multiloop check')")


def run(args) -> int:
    from importlib.util import find_spec

    from multiloop.web import serve
    if find_spec("bokeh") is None:
        raise InputError(explain("multiloop serve", expected="Bokeh", got="not installed (bokeh)",
                                 hint="pip install 'multiloop[web]'"))
    from multiloop.inputs import load_mechanism

    if not 0 <= args.port <= 65535:
        raise InputError(explain("--port", expected="0 … 65535", got=str(args.port)))
    files = {str(f): load_mechanism(f) for f in args.files}
    if args.atlas:
        from multiloop.catalogue.atlas import Atlas
        for db in args.atlas:
            Atlas(db, readonly=True).close()        # a bad atlas is an error before serving
    if args.host not in ("127.0.0.1", "localhost", "::1"):
        print(f"multiloop serve: warning: binding {args.host}: the page is reachable from the network "
              "and has no login; anyone who reaches it can run computations on this machine", file=sys.stderr)
    serve(files, port=args.port, host=args.host, open_browser=args.open, atlases=args.atlas,
          threshold=args.min_transmission,
          ready=lambda url: print(f"multiloop serve: {url} (Ctrl-C stops)", flush=True))
    return 0

