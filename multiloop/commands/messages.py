"""A library error's message in the command line's terms: each parameter it names becomes
the command's option flag, and a fault of the mechanism names the file it came from."""
import re

from multiloop.topo.errors import (AssemblyError, DecompositionError, LinkageError, MobilityError, ParameterError,
                                   SingularityError, TopologyError, cap_message)

__all__ = ["flagged", "message_of"]


#: errors about the mechanism a command read: their message names the file
_OF_THE_MECHANISM = (TopologyError, MobilityError, DecompositionError, AssemblyError, SingularityError)


def flagged(text: str, parameters, flags: dict[str, str]) -> str:
    """A :class:`~topo.errors.ParameterError`'s ``text`` in the command's terms: each of
    its ``parameters`` that is an option of the command becomes the option's flag
    (``flags``, from :func:`multiloop.cli._flags`), where the library names it: in the subject (the
    text before the first ``": "``) by its name, elsewhere quoted (``'start'``).

    >>> flagged("start/stop: expected both or neither, got only one", ("start", "stop"),
    ...         {"start": "--from", "stop": "--to"})
    '--from/--to: expected both or neither, got only one'
    >>> flagged("drivers: expected 'at' when the first driver is a P joint", ("drivers", "at"), {"at": "--at"})
    'drivers: expected --at when the first driver is a P joint'
    """
    head, sep, rest = text.partition(": ")
    for p in parameters:
        if p in flags:
            head = re.sub(rf"(?<![\w'-]){re.escape(p)}(?![\w'-])", lambda _, f=flags[p]: f, head)
            rest = rest.replace(f"'{p}'", flags[p])
    return head + sep + rest


def message_of(exc: LinkageError, args) -> str:
    """The error's message; the library parameters it names become the options' flags
    (:func:`flagged`), and a fault of the mechanism names the file it came from."""
    text = str(exc)
    if isinstance(exc, ParameterError):
        text = flagged(text, exc.parameters, args._flags)
    source = getattr(args, "file", None) or getattr(args, "input", None) or getattr(args, "start", None)
    if isinstance(exc, _OF_THE_MECHANISM) and isinstance(source, str) and source not in text:
        text = f"{source}: {text}"
    return cap_message(text)
