"""An edit's showing held back until its check is there, so that the page gets the new
drawing and its check in one go.

After an edit (a drop, a typed value, an undo, a structure edit) the page used to show
the new drawing at once and the check's report a round trip later.  Most checks of the
catalogue end within :data:`EDIT_WAIT_MS`: the drawing then waits for them and both
reach the page together (a longer job: the drawing when the wait is over, the report
when it ends).  Only the newest showing is ever made: a newer edit, or any other
design opened, replaces or drops the one held, and a held showing's timer that finds
another one held does nothing.
"""
from __future__ import annotations

__all__ = ["EDIT_WAIT_MS", "Hold"]

#: an edit's new drawing waits this long for its motion and check, so that the page
#: gets them in one message (a longer job: the drawing then, the check when it ends).
#: Two messages cost the page about twice one: at 250 ms the Stephenson III pair's and
#: the excavators' checks came apart and landed 390-630 ms after the drop, at 450 ms
#: together in 250-350 ms (``benchmarks/bench_web.py --edit-latency``)
EDIT_WAIT_MS = 450


class Hold:
    """The one showing held back (``show``, a function of no argument), or None.
    ``later(ms, fn)``, set by the server, calls ``fn`` in ``ms`` (its changes sent
    together); without it nothing is held."""

    def __init__(self):
        self.later = None
        self.show = None

    def open(self, show, hold: bool) -> None:
        """Make ``show`` the design's showing: at once, or (``hold``: an edit with a job
        to wait for) when :meth:`release` is called or :data:`EDIT_WAIT_MS` have passed,
        whichever comes first.  A showing held before is dropped."""
        self.show = show if hold and self.later is not None else None
        if self.show is None:
            show()
        else:
            self.later(EDIT_WAIT_MS, lambda: self.release(show))

    def release(self, show=None) -> None:
        """Show the showing held (``show``: only if it is still the one held)."""
        show = self.show if show is None else show
        if show is not None and self.show is show:
            self.show = None
            show()
