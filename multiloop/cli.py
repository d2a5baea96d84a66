"""The ``multiloop`` console command: parses arguments and dispatches.

Each sub-command lives in ``multiloop/commands/<name>.py`` with two functions,
``add_arguments(parser)`` and ``run(args) -> int``.  Exit codes: 0 success; 2 bad
input or environment (every ``topo.errors.LinkageError``, and any ``OSError`` such as
a permission denied or a directory given for a file), one message on stderr, no
traceback; 1 internal error (traceback only with ``--debug``); 130 interrupted.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from multiloop.commands.messages import flagged, message_of  # noqa: F401 - flagged: the commands' helper
from multiloop.topo.errors import LinkageError, cap_message

COMMANDS = {
    "analyse": "structural report of a chain or mechanism (Pozhbelko & Kuts 2020 numbers)",
    "decompose": "Assur groups in solving order",
    "solve": "positions, velocities, accelerations over the input range",
    "forces": "kinetostatics: reactions and balancing force/moment",
    "engine": "crank-slider engines: diagrams of Vasilenko et al. 2018",
    "platform": "six-strut spatial platform: strut forces, screws, frequencies",
    "atlas": "number/type synthesis: atlases of chains (SQLite, HTML)",
    "catalogue": "list the bundled mechanisms",
    "convert": "convert a mechanism between .toml, .json and .pyslvs (Pyslvs)",
    "check": "design check over the whole motion: limits, dead centres, transmission, circuits",
    "bench": "run the benchmarks and print ratios",
    "synthesise": "dimensional synthesis: path, function and motion generation",
    "serve": "web workbench: move a design, see its check, draw a target, browse atlases",
}


DESCRIPTION = ("Structure, Assur decomposition, kinematics, kinetostatics and atlases of planar "
               "multi-loop linkages with multiple joints.  Mechanisms are TOML or JSON files; "
               "'multiloop COMMAND --help' describes each command.")

EPILOG = ("exit codes: 0 success, 2 bad input (the message names the file, table and key at "
          "fault), 1 internal error (run with --debug for the traceback)")


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser.  With ``argv``, only the command it names is imported
    (its options and run function); the others are listed by name and help line alone, so
    that a command does not pay for the imports of every other (``serve`` starts ~1 s
    sooner).  Without ``argv``, every command is complete."""
    parser = argparse.ArgumentParser(prog="multiloop", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    parser.add_argument("--version", action="version", version="multiloop 0.1.0")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    chosen = None if argv is None else next((a for a in argv if not a.startswith("-")), "")
    for name, help_text in COMMANDS.items():
        if chosen is not None and name != chosen:
            sub.add_parser(name, help=help_text, description=help_text, add_help=False)
            continue
        try:
            module = importlib.import_module(f"multiloop.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"multiloop.commands.{name}":
                continue
            raise
        p = sub.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _flags=_flags(p))
    return parser


def _flags(p: argparse.ArgumentParser) -> dict[str, str]:
    """A command's options by the parameter they set, each by its long flag:
    ``{"tol": "--tol", "start": "--from", "links": "--links"}`` (not ``-n``)."""
    return {a.dest: next((o for o in a.option_strings if o.startswith("--")), a.option_strings[-1])
            for a in p._actions if a.option_strings}


def _tolerant_streams() -> None:
    """Print what the terminal cannot encode as escapes (a Latin-1 or ASCII terminal, a
    lone surrogate in a name) instead of failing with UnicodeEncodeError."""
    for stream in (sys.stdout, sys.stderr):
        if hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="backslashreplace")
            except (ValueError, OSError):  # pragma: no cover - a detached or closed stream
                pass


def main(argv: list[str] | None = None) -> int:
    _tolerant_streams()
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    from multiloop.outputs import quiet_warnings  # noqa: PLC0415

    try:
        with quiet_warnings(f"multiloop {args.command}"):   # one line per warning, no source path
            return int(args._run(args) or 0)
    except LinkageError as exc:
        print(f"multiloop {args.command}: error: {message_of(exc, args)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except OSError as exc:   # the environment refused a file: not a bug of multiloop
        where = f"'{exc.filename}'" if exc.filename else "a file"
        print(cap_message(f"multiloop {args.command}: error: {where}: {exc.strerror or exc}"), file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001 - the last line of defence
        if args.debug:
            raise
        print(f"multiloop {args.command}: internal error: {type(exc).__name__}: {cap_message(str(exc))} "
              "(run with --debug for the traceback, and please report it)", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
