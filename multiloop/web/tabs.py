"""A tab's end on the server: its jobs stop when its connection does.

Bokeh destroys a session only once it has gone unused for a while (15 s here, so that
a page that reconnects finds its work), and its clean-up hook came too late to stop a
synthesis (under Bokeh 3.9 removing a periodic callback there raised: the session's
callbacks are gone by then, and the rest of the hook never ran).  A :class:`TabWatch`
looks at the server's sessions every :data:`PERIOD_MS`: once a session that had a
connection has none, its page's ``lost()`` is called (the workbench cancels its jobs).
"""
from __future__ import annotations

__all__ = ["TabWatch", "PERIOD_MS"]

#: how often the sessions are looked at (ms)
PERIOD_MS = 250


class TabWatch:
    """The pages of one server, by session id, and which of them are connected."""

    def __init__(self):
        self.pages: dict[str, object] = {}        # session id -> lost()
        self.connected: set[str] = set()

    def add(self, session_id: str, lost) -> None:
        """Call ``lost()`` when session ``session_id`` loses its last connection."""
        self.pages[session_id] = lost

    def discard(self, session_id: str) -> None:
        """Forget a destroyed session."""
        self.pages.pop(session_id, None)
        self.connected.discard(session_id)

    def check(self, sessions) -> None:
        """One look at ``sessions`` (Bokeh ``ServerSession`` s)."""
        for s in sessions:
            if s.connection_count:
                self.connected.add(s.id)
            elif s.id in self.connected:
                self.connected.discard(s.id)
                lost = self.pages.get(s.id)
                if lost is not None:
                    lost()

    def start(self, server, app_path: str = "/") -> None:
        """Look at the sessions of ``server`` (a Bokeh ``BaseServer``) on its loop from now on."""
        from tornado.ioloop import PeriodicCallback
        PeriodicCallback(lambda: self.check(server.get_sessions(app_path)), PERIOD_MS).start()
