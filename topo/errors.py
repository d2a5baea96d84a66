"""The exception tree of multiloop.

Every error a user can provoke with bad input derives from :class:`LinkageError`
and, when the input is at fault, also from :class:`ValueError`.  Messages follow
the pattern *expected / got / hint*, built by :func:`explain`, so the CLI can print
them as they are (exit code 2, no traceback).

Tree (the one home of every multiloop exception; a new error class goes here)::

    LinkageError
    ├── InputError        (ValueError)  malformed file, unknown key, bad value
    │   ├── ParameterError              a function's argument out of its domain (names the parameter)
    │   └── OutputError                 an output target is unusable (multiloop.outputs)
    ├── TopologyError     (ValueError)  graph-level problem (disconnected, unknown link, ...)
    ├── MobilityError     (ValueError)  drivers do not fit the mobility
    ├── DecompositionError(ValueError)  not decomposable into Assur groups
    ├── AssemblyError     (ValueError)  the mechanism cannot assemble at an input value
    ├── SingularityError  (ValueError)  a singular position met in a single-position query
    │   └── SingularStrutsError         six platform struts on a linear complex
    └── ScrewPairingError (TypeError)   a twist paired with a twist (or a wrench with a wrench)
    SingularityWarning (UserWarning)    dead-centre / toggle positions in batches

The command line turns every :class:`LinkageError` into exit code 2 with its
message and no traceback; anything else is an internal error (exit 1).
"""
from __future__ import annotations

__all__ = [
    "LinkageError",
    "InputError",
    "TopologyError",
    "MobilityError",
    "DecompositionError",
    "AssemblyError",
    "SingularityError",
    "SingularStrutsError",
    "ScrewPairingError",
    "OutputError",
    "ParameterError",
    "SingularityWarning",
    "explain",
    "list_problems",
    "cap_message",
    "MAX_MESSAGE",
]

#: longest message the command line prints (characters)
MAX_MESSAGE = 8000

#: problems named one by one in a message; the rest are counted
MAX_LISTED = 8


def explain(what: str, expected: str | None = None, got: str | None = None,
            hint: str | None = None) -> str:
    """Format an error message as ``what: expected …, got …; hint: …``.

    Examples
    --------
    >>> explain("joint 'B'", expected="at least 2 links", got="1 link ('rod')",
    ...         hint="a pin must join two or more links")
    "joint 'B': expected at least 2 links, got 1 link ('rod'); hint: a pin must join two or more links"
    """
    body = []
    if expected is not None:
        body.append(f"expected {expected}")
    if got is not None:
        body.append(f"got {got}")
    msg = what + (": " + ", ".join(body) if body else "")
    if hint:
        msg += f"; hint: {hint}"
    return msg


def list_problems(problems: list[str], where: str = "the mechanism", more: bool = False) -> str:
    """One message for a list of problems: the first :data:`MAX_LISTED` named, the rest counted.

    ``more`` says the search stopped early, so the count is a lower bound.

    Examples
    --------
    >>> list_problems(["a: bad"])
    'a: bad'
    >>> print(list_problems([f"p{i}" for i in range(10)]))
    10 problems in the mechanism (the first 8 shown):
      - p0
      - p1
      - p2
      - p3
      - p4
      - p5
      - p6
      - p7
      - ... and 2 more
    """
    if len(problems) == 1 and not more:
        return cap_message(problems[0])
    n = f"{len(problems)}{' or more' if more else ''}"
    shown = problems[:MAX_LISTED]
    head = f"{n} problems in {where}" + (f" (the first {len(shown)} shown)" if len(problems) > len(shown) else "")
    rest = len(problems) - len(shown)
    lines = [cap_message(p, MAX_MESSAGE // (MAX_LISTED + 2)) for p in shown]
    if rest or more:
        lines.append(f"... and {rest}{' or more' if more else ''} more")
    return head + ":\n  - " + "\n  - ".join(lines)


def cap_message(text: str, limit: int = MAX_MESSAGE) -> str:
    """``text`` cut to at most about ``limit`` characters, saying how much was cut.

    Examples
    --------
    >>> cap_message("x" * 50, 20)
    'xxxxxxxxxxxxxxxxxxxx… (30 more characters)'
    """
    if len(text) <= limit:
        return text
    return text[:limit] + f"… ({len(text) - limit} more characters)"


class LinkageError(Exception):
    """Root of every multiloop error."""


class InputError(LinkageError, ValueError):
    """A mechanism file or an argument is malformed (names the table/key at fault)."""


class TopologyError(LinkageError, ValueError):
    """The chain's graph is not acceptable (disconnected, dangling, unknown names...)."""


class MobilityError(LinkageError, ValueError):
    """The drivers given do not fit the mobility of the mechanism."""


class DecompositionError(LinkageError, ValueError):
    """The mechanism cannot be split into Assur groups (names the free/surplus parts)."""


class AssemblyError(LinkageError, ValueError):
    """The mechanism cannot be assembled at the requested input value."""


class SingularityError(LinkageError, ValueError):
    """A single-position query hit a singular (dead-centre / toggle) position."""


class SingularStrutsError(SingularityError):
    """The six strut lines of a platform are (numerically) linearly dependent: they
    belong to a linear complex and the platform can move (Doronin 2015).

    Attributes
    ----------
    condition_number : float
        Condition number of the dimensionless Plücker matrix.
    """

    def __init__(self, message: str, condition_number: float):
        super().__init__(message)
        self.condition_number = condition_number


class ScrewPairingError(LinkageError, TypeError):
    """Two screws of kinds that cannot be paired (e.g. a twist with a twist)."""


class ParameterError(InputError):
    """An argument of a library function lies outside its domain (a NaN tolerance, a
    negative count), or arguments do not go together.  The message names parameters,
    never a command's options: it starts with the parameter at fault, ``parameter``
    (``start/stop: ...`` names two), and quotes any other it names (``'at'``).
    ``parameters`` lists every parameter it names, ``parameter`` first; the command line
    puts each option's flag in its place (``tol`` → ``--tol``, ``'start'`` → ``--from``).

    Examples
    --------
    >>> e = ParameterError(explain("tol", expected="a finite number >= 0", got="nan"), "tol")
    >>> e.parameter, e.parameters, str(e)
    ('tol', ('tol',), 'tol: expected a finite number >= 0, got nan')
    >>> e = ParameterError(explain("drivers", expected="'start' and 'stop' when R and P drivers are mixed",
    ...                            got="neither"), "drivers", "start", "stop")
    >>> e.parameters
    ('drivers', 'start', 'stop')
    """

    def __init__(self, message: str, parameter: str, *others: str):
        super().__init__(message)
        self.parameter = parameter
        self.parameters = (parameter, *others)


class OutputError(InputError):
    """An output target is unusable or refused the bytes (the CLI exits 2)."""


class SingularityWarning(UserWarning):
    """A batch met singular positions (they are marked in the status mask)."""
