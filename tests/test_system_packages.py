"""`qmesh setup`: which Debian packages each mode asks for, when apt-get runs, and the command
printed when it may not.

The README's first command runs `qmesh setup` after installing the viewer: Mesa only, never the
browser; its second runs `qmesh setup --test`: everything the test suite needs. apt-get is never
run for real here: a fake `run` plays dpkg-query and apt-get. One test asks the real dpkg of this
machine (the test suite itself needs every package installed).
"""

import io
import subprocess
import sys
import types

import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh import setup as sp
from qmesh.cli import main

ALL = [p for g in sp.GROUPS for p in g.packages]
# What each group installs, written out: the viewer's off-screen rendering, the browser tests,
# gmsh's wheel (the peers extra), NGSolve's OpenBLAS (the fem-ngsolve extra).
RENDERING = ["libegl1", "libgl1", "libgl1-mesa-dri"]
BROWSER = ["chromium", "libatomic1"]
GMSH = ["libgl1", "libglu1-mesa", "libxcursor1", "libxft2", "libxinerama1", "libxrender1",
        "libfontconfig1", "libgomp1"]
NGSOLVE = ["libgfortran5"]
NEEDED_BY = {"vtk": RENDERING, "playwright": BROWSER, "gmsh": GMSH, "ngsolve": NGSOLVE}


class FakeSystem:
    """dpkg-query answers from `installed`; apt-get install adds the packages (or fails)."""

    def __init__(self, installed=(), apt_status=0, dpkg=True):
        self.installed, self.apt_status, self.dpkg = set(installed), apt_status, dpkg
        self.calls = []

    def __call__(self, cmd, **kwargs):
        self.calls.append(list(cmd))
        if cmd[0] == "dpkg-query":
            if not self.dpkg:
                raise FileNotFoundError("dpkg-query")
            out = "".join(f"{p} installed\n" for p in cmd[3:] if p in self.installed)
            return types.SimpleNamespace(returncode=0 if out else 1, stdout=out)
        apt = cmd[cmd.index("apt-get"):]
        if apt[1] == "install" and self.apt_status == 0:
            self.installed |= {p for p in apt[2:] if not p.startswith("-")}
        return types.SimpleNamespace(returncode=self.apt_status, stdout="")

    def apt_calls(self):
        return [c for c in self.calls if "apt-get" in c]


def test_nothing_runs_when_all_is_installed():
    fake, out = FakeSystem(installed=ALL), io.StringIO()
    assert sp.setup(everything=True, run=fake, prefix=lambda run: [], out=out) == 0
    assert fake.apt_calls() == [] and len(fake.calls) == 1        # one dpkg-query
    assert "installed" in out.getvalue()


def test_root_installs_only_the_missing_packages_after_an_update():
    fake, out = FakeSystem(installed=["libegl1", "chromium"]), io.StringIO()
    assert sp.setup(everything=True, run=fake, prefix=lambda run: [], out=out) == 0
    update, install = fake.apt_calls()
    assert update[:2] == ["apt-get", "update"]
    assert install[:5] == list(sp.APT_INSTALL)
    assert set(install[5:]) == set(ALL) - {"libegl1", "chromium"}
    assert len(install[5:]) == len(set(install[5:]))                 # each package once


def test_sudo_prefix_is_used_when_given():
    fake = FakeSystem()
    assert sp.setup(everything=True, run=fake, prefix=lambda run: ["sudo", "-n"], out=io.StringIO()) == 0
    assert all(c[:4] == ["sudo", "-n", "env", "DEBIAN_FRONTEND=noninteractive"]
               for c in fake.apt_calls())


def test_without_root_it_prints_the_exact_command_and_fails():
    fake, out = FakeSystem(installed=ALL[1:]), io.StringIO()
    assert sp.setup(everything=True, run=fake, prefix=lambda run: None, out=out) == 1
    assert fake.apt_calls() == []
    assert f"run: sudo apt-get update && sudo {' '.join(sp.APT_INSTALL)} {ALL[0]}" in out.getvalue()


def test_check_only_never_installs():
    fake, out = FakeSystem(), io.StringIO()
    assert sp.setup(check_only=True, everything=True, run=fake, prefix=lambda run: [], out=out) == 1
    assert fake.apt_calls() == [] and "checked only" in out.getvalue()


def test_a_failing_apt_get_is_reported():
    fake, out = FakeSystem(apt_status=100), io.StringIO()
    assert sp.setup(everything=True, run=fake, prefix=lambda run: [], out=out) == 1
    assert "failed with exit status 100" in out.getvalue()


def test_no_dpkg_looks_for_the_libraries_and_programs(monkeypatch):
    """Where dpkg cannot tell: all found is fine; anything missing is named, with the packages."""
    out = io.StringIO()
    monkeypatch.setattr(sp.ctypes.util, "find_library", lambda name: f"lib{name}.so")
    monkeypatch.setattr(sp.shutil, "which", lambda name: f"/usr/bin/{name}")
    assert sp.setup(everything=True, run=FakeSystem(dpkg=False), out=out) == 0
    monkeypatch.setattr(sp.ctypes.util, "find_library", lambda name: None if name == "EGL" else "x")
    out = io.StringIO()
    assert sp.setup(everything=True, run=FakeSystem(dpkg=False), out=out) == 1
    assert "libEGL not found" in out.getvalue() and all(p in out.getvalue() for p in ALL)


def test_every_group_can_be_looked_for_without_dpkg():
    assert all(g.libraries for g in sp.GROUPS)
    assert sp.not_found(sp.GROUPS) == []          # this machine has them all (the tests need them)


def asked_for(modules, **mode) -> list[str]:
    """The packages `qmesh setup` (as root, nothing installed yet) gives apt-get when only the
    Python modules `modules` are installed."""
    fake = FakeSystem()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sp, "module_installed", lambda name: name in modules)
        assert sp.setup(run=fake, prefix=lambda run: [], out=io.StringIO(), **mode) == 0
    installs = [c for c in fake.apt_calls() if "install" in c]
    return installs[0][len(sp.APT_INSTALL):] if installs else []


def test_the_first_commands_setup_asks_for_mesa_only():
    """After `pip install -e ".[io,view]"` (VTK, no Playwright, no gmsh)."""
    assert asked_for({"vtk"}) == RENDERING
    assert asked_for(set()) == []


@settings(max_examples=16, deadline=None)
@given(modules=st.sets(st.sampled_from(sorted(NEEDED_BY))))
def test_each_mode_asks_for_its_packages(modules):
    """Plain `qmesh setup`: the packages of the installed modules, never the browser (only the
    tests need it); `--test`: every package the test suite needs, whatever is installed."""
    default = asked_for(modules)
    assert set(default) == {p for m in modules - {"playwright"} for p in NEEDED_BY[m]}
    assert not set(BROWSER) & set(default)
    assert len(default) == len(set(default))
    assert sorted(asked_for(modules, tests=True)) == sorted(set(RENDERING + BROWSER + GMSH + NGSOLVE))


def test_without_root_the_first_command_prints_the_apt_get_line_and_stops(monkeypatch):
    monkeypatch.setattr(sp, "module_installed", lambda name: name == "vtk")
    fake, out = FakeSystem(), io.StringIO()
    assert sp.setup(run=fake, prefix=lambda run: None, out=out) == 1
    assert fake.apt_calls() == []
    assert out.getvalue().endswith(f"run: sudo apt-get update && sudo {' '.join(sp.APT_INSTALL)} "
                                   f"{' '.join(RENDERING)}\n")


def test_the_command_line_has_a_test_mode():
    done = subprocess.run([sys.executable, "-m", "qmesh", "setup", "--help"], capture_output=True, text=True)
    assert done.returncode == 0 and "--test" in done.stdout
    done = subprocess.run([sys.executable, "-m", "qmesh", "setup", "--check", "--test", "--all"],
                          capture_output=True, text=True)
    assert done.returncode == 2 and "not allowed with argument" in done.stderr


def test_groups_follow_the_installed_extras():
    """Each group's module is what needs it; a module that is not installed needs nothing."""
    ghost = sp.Group("ghost", "no_such_module_qmesh", ("libghost",), "")
    assert sp.needed_groups(groups=(ghost,)) == []
    assert sp.needed_groups(everything=True, groups=(ghost,)) == [ghost]
    assert {g.module for g in sp.GROUPS} == {"vtk", "playwright", "gmsh", "ngsolve"}


def test_this_machine_has_every_package_and_the_command_is_quick(capsys):
    """The test suite needs them all (it renders, drives chromium, runs gmsh and NGSolve)."""
    assert sp.missing(sp.GROUPS) == []
    assert main(["setup", "--check", "--test"]) == 0
    assert "installed" in capsys.readouterr().out


def test_help_lists_setup():
    done = subprocess.run([sys.executable, "-m", "qmesh", "setup", "--help"], capture_output=True, text=True)
    assert done.returncode == 0 and "--check" in done.stdout


def test_require_names_the_missing_package_or_stays_silent():
    sp.require("rendering", run=FakeSystem(installed=ALL))
    sp.require("rendering", run=FakeSystem(dpkg=False))               # not Debian: cannot tell
    with pytest.raises(qmesh.QmeshError, match="libegl1") as caught:
        sp.require("rendering", run=FakeSystem(installed=["libgl1-mesa-dri"]))
    assert "qmesh setup" in str(caught.value) and "libgl1-mesa-dri" not in str(caught.value)
    with pytest.raises(qmesh.QmeshError, match="rendering"):
        sp.require("no such group")
