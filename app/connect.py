"""The page's first connection to the server, without an error in the browser's console.

trame's page connects to the server's websocket only after asking a session launcher for its
address: given no `sessionURL`, the client POSTs to `<page>/paraview/` (a ParaView-Web launcher's
endpoint) and, when that fails, falls back to `ws://<host>/ws`. A plain trame server has no
launcher, so every page load logged "405 (Method Not Allowed)" before connecting. The server
answers that request itself with the websocket's address, which the client then connects to.
"""

from __future__ import annotations

LAUNCHER_PATH = "/paraview/"
"""Where trame's client asks for a session (its default `sessionManagerURL`)."""


def session_url(path: str, prefix: str = "") -> str:
    """The websocket beside the page that asked at `path` (…/paraview/), behind a proxy's
    `prefix` (X-Forwarded-Prefix): the client puts the page's host for USE_HOST, and `wss:` for
    `ws:` on an https page."""
    base = path[:len(path) - len("paraview/")] if path.endswith("paraview/") else "/"
    return f"ws://USE_HOST{prefix.rstrip('/')}{base}ws"


async def _launcher(request):
    from aiohttp import web
    return web.json_response({"sessionURL": session_url(
        request.path, request.headers.get("X-Forwarded-Prefix", ""))})


def answer_launcher(server) -> None:
    """Have the trame `server` answer its page's launcher request (before it starts)."""
    def bind(wslink_server):
        wslink_server.app.router.add_post(LAUNCHER_PATH, _launcher)
    server.controller.on_server_bind.add(bind)
