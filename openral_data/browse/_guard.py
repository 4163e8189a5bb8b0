"""browse is a local tool: an ASGI middleware in front of the app that answers only requests naming the server
itself, so a web page elsewhere can neither read the datasets nor keep the server busy.

* Host: `localhost`, the name or IP literal the server listens on (`--host`; any IP literal when it listens on
  all interfaces: an address, unlike a DNS name, cannot be rebound to another site); anything else (a DNS-rebinding
  page's `attacker.example:8765`) gets 421 Misdirected Request, as does a port other than the server's.
* Origin: the JSON API and the media (videos, depth frames, pictures: each a query or a decode) answer only
  same-origin requests: `Sec-Fetch-Site`, when sent, is `same-origin` or `none` (typed in the address bar), and
  `Origin`, when sent, is the server's own. The pages and their static assets answer any request (a link from
  elsewhere opens them; they hold no data).
"""

from __future__ import annotations

import ipaddress
import re
from collections.abc import Awaitable, Callable, MutableMapping
from typing import Any

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

WILDCARDS = ("0.0.0.0", "::", "")
EXPENSIVE = re.compile(r"^/api/|^/d/[^/]+/(video|depth|picture)/")
SAME_SITE = ("same-origin", "none")


class LocalOnly:
    """`app` behind the Host and Origin checks of a server listening on `host`:`port` (port 0: not checked)."""

    def __init__(self, app: ASGIApp, host: str, port: int = 0) -> None:
        self.app = app
        self.host = host.strip("[]")
        self.port = port

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        host = headers.get("host", "")
        if not self.host_allowed(host):
            await _refuse(send, 421, "Host: not this server (browse answers only localhost and its own address)")
            return
        if EXPENSIVE.match(scope.get("path", "")) and not same_origin(headers, host):
            await _refuse(send, 403, "Origin: not this server (the API and media answer same-origin requests only)")
            return
        await self.app(scope, receive, send)

    def host_allowed(self, value: str) -> bool:
        """`value` (a Host header) names this server: localhost or an allowed IP literal, and our port."""
        match = re.fullmatch(r"(\[[^\]]*\]|[^:\[\]]*)(?::(\d{1,5}))?", value.strip())
        if match is None:
            return False
        name, port = match.group(1).strip("[]").lower(), match.group(2)
        if port is not None and self.port and int(port) != self.port:
            return False
        if name in ("localhost", self.host.lower()):  # ... or the name it was told to listen on (--host NAME)
            return True
        try:
            address = ipaddress.ip_address(name)
        except ValueError:
            return False  # a DNS name: what a rebinding page sends
        if self.host in WILDCARDS:
            return True
        if self.host == "localhost":
            return address.is_loopback
        try:
            return address == ipaddress.ip_address(self.host)
        except ValueError:
            return False  # listening on a name: that name (above) and localhost only


def same_origin(headers: dict[str, str], host: str) -> bool:
    """The request comes from a page of this server (or from no page at all: curl, the address bar)."""
    site = headers.get("sec-fetch-site")
    if site is not None and site not in SAME_SITE:
        return False
    origin = headers.get("origin")
    return origin is None or origin in (f"http://{host}", f"https://{host}")


async def _refuse(send: Send, status: int, text: str) -> None:
    body = ('{"error": "' + text + '"}').encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())],
        }
    )
    await send({"type": "http.response.body", "body": body})
