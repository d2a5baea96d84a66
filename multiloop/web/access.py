"""Who may use the served page: a token, a host check, an origin check, and the headers
of every answer (the conventions of Jupyter Server's local server).

* **Token.**  Each start makes a fresh random token (:func:`new_token`); the address
  ``serve`` prints carries it (``http://127.0.0.1:PORT/?token=TOKEN``).  A request
  carries it in its query, or in the cookie that the first answer to the token gave the
  browser (``HttpOnly``, ``SameSite=Strict``, named after the port): the page's scripts
  and its websocket then need nothing more.  Anything else is refused (403) before Bokeh
  sees it, so no session is made for it.
* **Host.**  Only ``127.0.0.1:PORT``, ``localhost:PORT``, ``[::1]:PORT`` and the address
  bound are accepted as ``Host`` (a DNS-rebinding page names its own host there).
* **Origin.**  A request that names its ``Origin`` (every websocket from a browser
  does) must come from one of those hosts; a websocket without one is refused.
* **Headers.**  ``Content-Security-Policy: frame-ancestors 'none'`` and
  ``X-Frame-Options: DENY`` (no other site may frame the page), ``Referrer-Policy:
  no-referrer`` (a link followed from the page does not pass the token on).
"""
from __future__ import annotations

import hmac
import re
import secrets
from dataclasses import dataclass
from functools import partial

from tornado.web import OutputTransform, RequestHandler

__all__ = ["Access", "Refused", "Headers", "new_token", "netloc", "TOKEN_PATTERN", "LOCAL_HOSTS"]

#: the hosts a local page is always reached by
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")

#: what a token may hold: it goes into an address and a cookie as it is
TOKEN_PATTERN = re.compile(r"[A-Za-z0-9_-]{8,}")

#: the headers of every answer
HEADERS = {"Content-Security-Policy": "frame-ancestors 'none'", "X-Frame-Options": "DENY",
           "Referrer-Policy": "no-referrer"}


def new_token() -> str:
    """A fresh random token (32 bytes, URL-safe base64)."""
    return secrets.token_urlsafe(32)


def netloc(host: str, port: int) -> str:
    """``host:port`` as a ``Host`` header names it (an IPv6 address in brackets)."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


@dataclass(frozen=True)
class Access:
    """The rules of one server: its ``port``, its ``token`` (None: none asked) and the
    ``Host`` headers it accepts (``hosts``, lower case)."""

    port: int
    token: str | None
    hosts: frozenset[str]

    @classmethod
    def of(cls, host: str, port: int, token: str | None) -> Access:
        """The rules of a server bound to ``host:port``."""
        return cls(port, token, frozenset(netloc(h, port).lower() for h in (*LOCAL_HOSTS, host)))

    @property
    def cookie(self) -> str:
        """The name of the token's cookie (one per port: cookies do not tell ports apart)."""
        return f"multiloop-token-{self.port}"

    def url(self, host: str) -> str:
        """The page's address on ``host``, with the token."""
        return f"http://{netloc(host, self.port)}/" + (f"?token={self.token}" if self.token else "")

    def _given(self, request, cookie: bool = True) -> str:
        """The token a request carries: in its query, else (``cookie``) in its cookie."""
        values = request.query_arguments.get("token") or []
        if values:
            return values[-1].decode("utf-8", "replace")
        morsel = request.cookies.get(self.cookie) if cookie else None
        return morsel.value if morsel is not None else ""

    def _token_ok(self, given: str) -> bool:
        return self.token is None or hmac.compare_digest(given.encode(), self.token.encode())

    def refusal(self, request) -> str | None:
        """Why ``request`` (a Tornado ``HTTPServerRequest``) is refused; None when it is served."""
        host = request.headers.get("Host", "").lower()
        if host not in self.hosts:
            return f"Host {host!r} is not this server's; hint: open the address multiloop serve printed"
        origin = request.headers.get("Origin")
        if origin is None and request.headers.get("Upgrade", "").lower() == "websocket":
            return "a websocket without an Origin"
        if origin is not None and origin.lower() not in {f"http://{h}" for h in self.hosts}:
            return f"Origin {origin!r} is not this server's"
        given = self._given(request)
        if not self._token_ok(given):
            return (f"{'a wrong' if given else 'no'} token; hint: open the address multiloop serve printed "
                    "(http://…/?token=…)")
        return None

    def grants_cookie(self, request) -> bool:
        """Whether the answer to ``request`` sets the token's cookie (it carried the token
        in its query)."""
        given = self._given(request, cookie=False)
        return self.token is not None and bool(given) and self._token_ok(given)

    def transform(self):
        """The Tornado output transform that adds :class:`Headers` to every answer."""
        return partial(Headers, self)


class Refused(RequestHandler):
    """The answer to a refused request: 403 and the reason, one line."""

    def initialize(self, reason: str) -> None:
        self.reason = reason

    def prepare(self) -> None:
        self.set_status(403)
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish(f"multiloop serve: refused: {self.reason}\n")


class Headers(OutputTransform):
    """Adds the headers of every answer (:data:`HEADERS`), and the token's cookie to the
    answer to a request that carried the token in its query."""

    def __init__(self, access: Access, request):
        self.cookie = access.grants_cookie(request)
        self.access = access

    def transform_first_chunk(self, status_code, headers, chunk, finishing):
        for k, v in HEADERS.items():
            headers[k] = v
        if self.cookie:
            headers.add("Set-Cookie", f"{self.access.cookie}={self.access.token}; Path=/; HttpOnly; SameSite=Strict")
        return status_code, headers, chunk

    def transform_chunk(self, chunk, finishing):
        return chunk
