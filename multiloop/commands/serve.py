"""``multiloop serve [FILE ...] [--port P] [--host H] [--open] [--atlas DB] [--token T | --no-token]``: the web workbench.

Serves a local page (a Bokeh server, the ``[web]`` extra) to open a mechanism, move it,
see its design check and structure, synthesise a path generator from a drawn or uploaded
target, and browse stored atlases (docs/web.md).  It binds 127.0.0.1 unless ``--host``
asks for another address (with a warning), and prints the page's address with a fresh
token (``--token`` sets it, ``--no-token`` asks for none, with a warning).  The files
given are read before serving, so a bad file is an error (exit 2) and nothing is
served.  The server writes no file; only the user's downloads leave it.
"""
from __future__ import annotations

import errno
import sys

from multiloop.topo.errors import InputError, explain

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument("files", nargs="*", metavar="FILE", help="mechanisms to open (.toml, .json, .pyslvs or catalogue names)")
    p.add_argument("--port", type=int, default=5006, help="port (default 5006; 0 picks a free one)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1; another one exposes the page to the network)")
    p.add_argument("--open", action="store_true", help="open the page (its address with the token) in the default browser")
    who = p.add_mutually_exclusive_group()
    who.add_argument("--token", metavar="VALUE",
                     help="the page's token (default: a fresh random one each start; 8 or more of A-Z a-z 0-9 - _)")
    who.add_argument("--no-token", action="store_true",
                     help="ask no token (a warning: any program on this machine can then use the page)")
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
    from multiloop.web.menus import file_entries
    files = dict(zip(file_entries(args.files), (load_mechanism(f) for f in args.files)))
    if args.atlas:
        from multiloop.catalogue.atlas import Atlas
        for db in args.atlas:
            Atlas(db, readonly=True).close()        # a bad atlas is an error before serving
    _check_token(args)
    from multiloop.web.jobs import log_to
    log_to(sys.stderr)
    try:
        serve(files, port=args.port, host=args.host, open_browser=args.open, atlases=args.atlas,
              threshold=args.min_transmission, token=args.token, require_token=not args.no_token,
              ready=lambda url: print(f"multiloop serve: {url} (Ctrl-C stops)", flush=True))
    except OSError as exc:
        if exc.errno != errno.EADDRINUSE:
            raise
        raise InputError(explain(f"port {args.port} is in use", hint="--port 0 picks a free one")) from None
    return 0


def _check_token(args) -> None:
    """The token's form, and the warnings of a page open to more than this user."""
    from multiloop.web.access import LOCAL_HOSTS, TOKEN_PATTERN
    if args.token is not None and not TOKEN_PATTERN.fullmatch(args.token):
        raise InputError(explain("--token", expected="8 or more characters of A-Z, a-z, 0-9, '-' and '_'",
                                 got=f"{len(args.token)} characters" if len(args.token) < 8 else "another character",
                                 hint="leave --token out for a fresh random one"))
    if args.no_token:
        print("multiloop serve: warning: --no-token: any program or user of this machine that reaches the port "
              "can use the page and run computations", file=sys.stderr)
    if args.host not in LOCAL_HOSTS:
        print(f"multiloop serve: warning: binding {args.host}: the page is reachable from the network; "
              "the token is its only lock and the connection is not encrypted", file=sys.stderr)

