"""The viewer's memory guard (qmesh_view.memory): a request is refused when what the whole of it
costs (mesher, kept stages, measures, views) would not fit, with the budget and the largest
target that fits named; that target is accepted; under a real address-space limit an accepted
request runs to its end without running out of memory."""

import json
import re
import subprocess
import sys

import pytest

from qmesh.errors import QmeshError
from qmesh.mesher import budget
from qmesh_view import memory
from qmesh_view.session import Session

MIB = 2**20


def largest_named(message: str) -> int:
    found = re.search(r"the largest target that fits is about (\d+)", message)
    assert found, message
    return int(found.group(1))


def test_a_small_budget_refuses_what_the_whole_request_costs_and_accepts_what_fits():
    allowed = memory.held_bytes() + 250 * MIB            # 250 MiB beside what the test holds
    s = Session(memory_budget=allowed)
    # 60,000 vertices: the mesher alone fits in 250 MiB, the whole request does not
    assert budget.estimate_bytes(60_000, varying=False) < 250 * MIB
    out = s.change("target_vertices", 60_000)
    assert out.kind == "refused", out
    assert f"memory budget ({memory.gib(allowed)})" in out.message, out.message
    assert s.params.target_vertices == 212                       # nothing replaced
    most = largest_named(out.message)
    assert 1000 < most < 60_000
    assert s.refusal("target_vertices", most) is None            # told before meshing: fits
    assert s.refusal("target_vertices", 2 * most) is not None
    out = s.change("target_vertices", most)
    assert out.ok and s.params.target_vertices == most, out
    # an s as text and a medium are counted at their own figures: refused at the same count
    for change in ({"q_mode": "expression", "s_text": "exp(x) + y**2"}, {"domain": "inclusion"}):
        assert s.refusal("target_vertices", 3 * most) is not None
        out = s.change(**change, target_vertices=60_000)
        assert out.kind in ("refused", "adjusted") and "memory budget" in out.message, out


def test_a_budget_smaller_than_what_the_viewer_holds_refuses_every_target():
    with pytest.raises(QmeshError, match="no target fits"):
        Session(memory_budget=memory.held_bytes() // 2)
    with pytest.raises(QmeshError, match="must be > 0"):
        memory.check(300, "constant", 0)


def test_the_estimate_grows_with_the_target_and_exceeds_the_mesher_alone():
    for kind in memory.BYTES_PER_VERTEX:
        small, large = (memory.request_bytes(n, kind) for n in (10_000, 1_000_000))
        assert small < large
        varying = kind != "constant" and kind != "medium"
        assert large > 3 * budget.estimate_bytes(1_000_000, varying=varying)
        assert memory.request_bytes(1_000_000, kind, virtual=True) >= large
        room = memory.request_bytes(123_456, kind)
        assert memory.request_bytes(memory.largest_target(room, kind), kind) <= room
        assert memory.request_bytes(memory.largest_target(room, kind) + 1, kind) > room


LIMITED = r"""
import json, os, re, resource, sys
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
from qmesh_view.draw import ViewSet
from qmesh_view.session import Session

def status(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field):
                return int(line.split()[1]) * 1024

views = ViewSet()
s = Session(target_vertices=300)
def show():
    views.draw(s.current, s.anisotropy, domain=s.domain)
    views.images()
s.controller.finish(); s.status(); s.convergence(); show()    # a first request, as a server
limit = status("VmSize:") + int(sys.argv[1])
resource.setrlimit(resource.RLIMIT_AS, (limit, resource.RLIM_INFINITY))
out = s.change("target_vertices", 1_000_000)
most = int(re.search(r"fits is about (\d+)", out.message).group(1)) if out.kind == "refused" else None
done = s.change("target_vertices", most) if most else None
if done is not None and done.ok:
    show()
while done is not None and done.ok and not s.at_end:       # every stage measured and drawn
    done = s.step()
    if done.ok:
        s.status()
        show()
rows = s.convergence() if done is not None and done.ok else None
print(json.dumps({"refused": out.kind == "refused", "message": out.message, "most": most,
                  "done": None if done is None else [done.kind, done.message],
                  "n": s.current.mesh.n_vertices, "kappa2": None if rows is None else rows["kappa2"][-1],
                  "limit": limit, "peak": status("VmPeak:"), "hwm": status("VmHWM:")}))
"""


def test_under_an_address_space_limit_the_accepted_request_runs_to_its_end():
    """A real RLIMIT_AS 500 MiB above what a server that drew a first request maps: 1e6 is
    refused naming the limit, the largest target named is meshed, measured and drawn to its end."""
    room = 500 * MIB
    out = subprocess.run([sys.executable, "-c", LIMITED, str(room)], capture_output=True,
                         text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["refused"] and "address-space limit" in r["message"], r
    assert r["most"] and r["most"] > 1000, r
    assert r["done"][0] == "applied", r                    # no MemoryError, no refusal
    assert abs(r["n"] - r["most"]) < 0.1 * r["most"], r    # the run reached its target
    assert r["kappa2"] is not None, r                      # and its measures were made
    assert r["peak"] <= r["limit"] and r["hwm"] <= r["limit"], r
