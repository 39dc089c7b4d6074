"""qmesh_view.delivery: remote frames re-pushed every 10 ms until encoded, never dropped."""

import types

from qmesh_view import delivery


class FakeImageDelivery:
    """The parts of trame-vtk's vtkWebPublishImageDelivery that `fast_image_delivery` uses."""

    def __init__(self):
        self.delta_stale_time_before_render = 0.5
        self.stale_handler_count = {"7": 1}
        self.pushes = []

    def push_render(self, view_id, ignore_animation=False, stale_count=0):
        self.pushes.append((view_id, stale_count))

    def render_stale_image(self, view_id, stale_count=0):   # the original: may drop a frame
        raise AssertionError("the original retry must be replaced")


def _server(*links):
    protocol = types.SimpleNamespace(getLinkProtocols=lambda: list(links))
    return types.SimpleNamespace(protocol=protocol)


def test_retuned_retry_pushes_again_until_the_limit_and_frees_its_handler():
    link = FakeImageDelivery()
    other = types.SimpleNamespace()                          # another link protocol: left alone
    assert delivery.fast_image_delivery(_server(other, link)) is link
    assert link.delta_stale_time_before_render == delivery.STALE_RETRY
    assert delivery.frames_pending(link)
    for count in (0, 1, 2, 37):                              # every later retry pushes again
        link.stale_handler_count["7"] = 1
        link.render_stale_image("7", count)
        assert link.pushes[-1] == ("7", count + 1)
        assert link.stale_handler_count["7"] == 0
    assert not delivery.frames_pending(link)
    limit = int(delivery.RETRY_FOR / delivery.STALE_RETRY)
    n = len(link.pushes)
    link.render_stale_image("7", limit)                      # given up after RETRY_FOR seconds
    assert len(link.pushes) == n


def test_twice_is_harmless_and_no_protocol_yet_is_none():
    link = FakeImageDelivery()
    delivery.fast_image_delivery(_server(link))
    retry = link.render_stale_image
    assert delivery.fast_image_delivery(_server(link)) is link
    assert link.render_stale_image is retry
    assert delivery.fast_image_delivery(types.SimpleNamespace(protocol=None)) is None
    assert not delivery.frames_pending(None)
