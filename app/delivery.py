"""Faster frames for server-rendered (remote) views: trame-vtk's image delivery, retuned.

trame-vtk answers a push with the previous frame while the new one is still being JPEG-encoded
in a thread, then waits `delta_stale_time_before_render` (0.5 s) before pushing again: that wait
would be most of the time a click takes to reach the screen (`benchmarks/bench_view.py
--browser` measures it). Its own retry also drops the frame when a short wait is not enough twice
in a row.
`fast_image_delivery` sets the wait to `STALE_RETRY` and replaces the retry with a plain one:
push again every `STALE_RETRY` seconds until the frame is encoded (at most `RETRY_FOR`).
Used by the trame app and by the widget's live (trame) views.

In the browser, trame's websocket hands every message over as a Blob, which wslink's client reads
back asynchronously (`Blob.arrayBuffer()`, twice per message): on a busy machine each of those
reads waited long enough to be a large part of the time from a push to the picture on screen.
`ARRAY_BUFFER_SOCKET` (a page script) switches the socket to ArrayBuffer messages on its first
send, and gives ArrayBuffer the `arrayBuffer()` the client calls, so a frame is decoded as soon
as it arrives.

The browser shares the machine with the server that renders the frames: every animation on the
page (an indeterminate progress bar, button ripples, CSS transitions) has Chromium lay out,
paint and composite a new page at the display's frame rate for as long as it runs, a core's
worth of work in a headless or software-rendered browser, taken from the server while it meshes
and renders. `QUIET_PAGE` (a style sheet) turns them off; the app's busy bar is a still line.
"""

from __future__ import annotations

STALE_RETRY = 0.01   # seconds between re-pushes of a frame still being encoded
RETRY_FOR = 2.0      # seconds after which a frame that never got encoded is given up


ARRAY_BUFFER_SOCKET = """
(() => {
  if (window.__qmeshArrayBufferSocket) return;
  window.__qmeshArrayBufferSocket = true;
  if (!ArrayBuffer.prototype.arrayBuffer) {
    Object.defineProperty(ArrayBuffer.prototype, 'arrayBuffer', {
      value() { return Promise.resolve(this); }, configurable: true, writable: true});
  }
  const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (...args) {
    if (this.binaryType !== 'arraybuffer') this.binaryType = 'arraybuffer';
    return send.apply(this, args);
  };
})();
"""
"""A page script: the page's websockets deliver ArrayBuffers, not Blobs, from their next send on
(the client's first request after the script runs); messages already on their way as Blobs are
read as before."""


QUIET_PAGE = """
*, *::before, *::after { transition: none !important; animation: none !important; }
.v-ripple__container { display: none !important; }
"""
"""A style sheet: no CSS transitions, CSS animations or ripples on the page."""


def _stale_retry(link):
    """A `render_stale_image` for trame-vtk's image delivery `link` that never drops a frame."""
    limit = int(RETRY_FOR / STALE_RETRY)

    def retry(view_id, stale_count=0):
        counts = link.stale_handler_count
        counts[view_id] = max(0, counts.get(view_id, 1) - 1)
        if stale_count < limit:
            link.push_render(view_id, False, stale_count + 1)
    return retry


def fast_image_delivery(server):
    """Retune the image delivery of a running trame `server`; its link protocol, or None when
    the server has no protocol yet (call again once it runs). Calling it twice is harmless."""
    protocol = getattr(server, "protocol", None)
    for link in protocol.getLinkProtocols() if protocol is not None else ():
        if hasattr(link, "render_stale_image") and hasattr(link, "push_render"):
            if not getattr(link, "_qmesh_fast", False):
                link.delta_stale_time_before_render = STALE_RETRY
                link.render_stale_image = _stale_retry(link)
                link._qmesh_fast = True
            return link
    return None


def frames_pending(link) -> bool:
    """True while some view of `link` still has a frame being encoded or waiting to be sent."""
    return link is not None and any(link.stale_handler_count.values())
