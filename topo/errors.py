"""The exception tree of multiloop.

Every error a user can provoke with bad input derives from :class:`LinkageError`
and, when the input is at fault, also from :class:`ValueError`.  Messages follow
the pattern *expected / got / hint*, built by :func:`explain`, so the CLI can print
them as they are (exit code 2, no traceback).

Tree (the one home of every multiloop exception; a new error class goes here)::

    LinkageError
    ├── InputError        (ValueError)  malformed file, unknown key, bad value
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
    "SingularityWarning",
    "explain",
]


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


class OutputError(InputError):
    """An output target is unusable or refused the bytes (the CLI exits 2)."""


class SingularityWarning(UserWarning):
    """A batch met singular positions (they are marked in the status mask)."""
