"""The default memory budget honours the process's own limits (RLIMIT_AS, a memory cgroup) and
`qmesh mesh --disk VB` is refused from the count the disk implies before its points are made."""

import resource
import subprocess
import sys

import pytest

from qmesh.cli import disk_vertices

import qmesh
from qmesh.mesher import budget

LIMIT = 3 * 2**30      # an address-space limit the interpreter, NumPy and SciPy start under

CHILD = r"""
import resource, sys, time
from qmesh.cli import main
resource.setrlimit(resource.RLIMIT_AS, (int(sys.argv[1]), resource.RLIM_INFINITY))
from qmesh.mesher import budget
print("budget", budget.default_budget(), flush=True)
code = main(["mesh", "--disk", "16", "--target-vertices", sys.argv[2], "-o", sys.argv[3], "--quiet"])
# the peak resident set of this process (VmHWM: ru_maxrss may carry a parent's peak over exec)
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
print("peak", int(hwm) * 1024, "code", code, flush=True)
"""


def run_limited(tmp_path, target: int, limit: int = LIMIT):
    out = subprocess.run([sys.executable, "-c", CHILD, str(limit), str(target), str(tmp_path / "m.vtu")],
                         capture_output=True, text=True, timeout=120)
    words = out.stdout.split()
    return out, int(words[words.index("budget") + 1]), int(words[words.index("peak") + 1])


def test_a_target_over_the_address_space_limit_is_refused_naming_the_limit(tmp_path):
    """Under a 3 GiB RLIMIT_AS the budget is at most 80% of what the limit leaves (not half of
    the machine's memory): 1e7 vertices are refused at once, naming the limit, with nothing of
    that size allocated."""
    out, limited, peak = run_limited(tmp_path, 10**7)
    assert limited < budget.LIMIT_FRACTION * LIMIT
    assert "code 2" in out.stdout
    err = out.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("qmesh: error:"), out.stderr
    assert "RLIMIT_AS" in err[0] and "3.00 GiB" in err[0] and "1e+07 vertices" in err[0]
    assert peak < 400 * 2**20                       # the interpreter and its imports: nothing of 1e7


def test_a_target_within_the_limit_still_meshes(tmp_path):
    out, _, _ = run_limited(tmp_path, 2000)
    assert "code 0" in out.stdout, out.stderr
    assert qmesh.io.read(tmp_path / "m.vtu").n_vertices > 1000


def test_the_smaller_of_half_the_memory_and_the_limit_is_the_budget(monkeypatch):
    monkeypatch.setattr(budget, "available_bytes", lambda: 16 * 2**30)
    monkeypatch.setattr(budget, "process_limits", lambda: [])
    assert budget.default_budget_of() == (8 * 2**30, "half the memory available now")
    monkeypatch.setattr(budget, "process_limits", lambda: [(2**30, "a limit"), (4 * 2**30, "another")])
    size, whose = budget.default_budget_of()
    assert size == int(budget.LIMIT_FRACTION * 2**30) and "a limit" in whose
    with pytest.raises(qmesh.QmeshError, match="what a limit leaves"):
        budget.check(10**7, varying=False)


def test_a_cgroup_limit_is_read(monkeypatch, tmp_path):
    for version, (limit_file, usage_file) in {"v2": ("memory.max", "memory.current"),
                                              "v1": ("memory.limit_in_bytes", "memory.usage_in_bytes")}.items():
        folder = tmp_path / version
        folder.mkdir()
        (folder / limit_file).write_text(f"{2 * 2**30}\n")
        (folder / usage_file).write_text(f"{2**29}\n")
        monkeypatch.setattr(budget, "_cgroup_dirs", lambda folder=folder: [str(folder)])
        monkeypatch.setattr(resource, "getrlimit", lambda _: (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
        [(free, what)] = budget.process_limits()
        assert free == 2 * 2**30 - 2**29 and limit_file in what and "2.00 GiB" in what
        (folder / limit_file).write_text("max\n")           # no limit
        assert budget.process_limits() == []


def test_the_disk_alone_is_refused_before_its_points_are_made(monkeypatch, capsys):
    """--disk 10000000 with the default size implies ~2e12 vertices; with a target, at least
    its 1e7 boundary points: refused from the count, no Disk built."""
    from qmesh import cli
    from qmesh.domain import domain
    made, real = [], domain.Disk
    monkeypatch.setattr(domain, "Disk", lambda vb: made.append(vb) or real(vb))
    monkeypatch.setattr(budget, "available_bytes", lambda: 8 * 2**30)
    monkeypatch.setattr(budget, "process_limits", lambda: [])
    for extra, count in (([], "2.19e+12"), (["--target-vertices", "10000001"], "1e+07")):
        assert cli.main(["mesh", "--disk", "10000000", *extra, "-o", "x.vtu"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"implies {count} vertices" in err[0] and "--disk 10000000" in err[0], err
    assert 10000000 not in made        # the 64-gon disk_vertices measures on is made


@pytest.mark.parametrize("vb, target", [(100, None), (3000, 5000), (64, 500)])
def test_the_disks_count_is_what_the_plan_expects_or_less(vb, target):
    from qmesh.mesher.options import Options
    from qmesh.mesher.plan import plan
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    implied = disk_vertices(vb, A, target_vertices=target)
    expected = plan(qmesh.Disk(vb), A, Options(target_vertices=target)).expected
    assert implied <= expected * 1.01 and implied >= 0.9 * min(expected, max(vb, target or 0))


FIELD_CHILD = r"""
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (int(sys.argv[1]), resource.RLIM_INFINITY))
import qmesh
F = qmesh.TensorField.principal(100, 1, "30*x")
try:
    m = qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), F, target_vertices=int(float(sys.argv[2])))
    print("meshed", m.n_vertices)
except qmesh.QmeshError as e:
    print("refused", e)
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
print("peak", int(hwm) * 1024, flush=True)
"""


@pytest.mark.parametrize("target", ["5e5", "4e7"])
def test_a_field_over_the_address_space_limit_is_refused_before_its_metric_is_built(target):
    """A field's metric table was built before the budget was asked: under 1 GiB of address
    space, 5e5 vertices ended in MemoryError and 4e7 took seconds and gigabytes first."""
    out = subprocess.run([sys.executable, "-c", FIELD_CHILD, str(2**30), target], capture_output=True,
                         text=True, timeout=120)
    assert "refused" in out.stdout and "with a field need" in out.stdout, out.stdout + out.stderr
    assert "RLIMIT_AS" in out.stdout and "MemoryError" not in out.stderr
    words = out.stdout.split()
    assert int(words[words.index("peak") + 1]) < 400 * 2**20


def test_a_memory_error_the_estimate_missed_is_said_as_a_qmesh_error(monkeypatch):
    import qmesh.meshing as meshing

    def allocation_fails(*args, **kwargs):
        raise MemoryError("Unable to allocate 256. MiB")
    monkeypatch.setattr(meshing.loop, "mesh", allocation_fails)
    with pytest.raises(qmesh.QmeshError, match="ran out of memory.*256. MiB.*fewer vertices"):
        qmesh.mesh(qmesh.Disk(16), qmesh.Anisotropy.constant([[1, 0], [0, 1]]), target_vertices=50)

    def steps_fail(*args, **kwargs):
        yield from ()
        raise MemoryError()
    monkeypatch.setattr(meshing.loop, "iterate", steps_fail)
    with pytest.raises(qmesh.QmeshError, match="ran out of memory"):
        list(qmesh.iterate(qmesh.Disk(16), qmesh.Anisotropy.constant([[1, 0], [0, 1]]), target_vertices=50))
