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
SESSION = {"sessionURL": "ws://USE_HOST/ws"}
"""The answer: the client puts the page's host for USE_HOST, and `wss:` on an https page."""


async def _launcher(request):
    from aiohttp import web
    return web.json_response(SESSION)


def answer_launcher(server) -> None:
    """Have the trame `server` answer its page's launcher request (before it starts)."""
    def bind(wslink_server):
        wslink_server.app.router.add_post(LAUNCHER_PATH, _launcher)
    server.controller.on_server_bind.add(bind)
