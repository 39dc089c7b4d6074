"""The Debian/Ubuntu packages that qmesh's extras need beyond pip, checked and installed by `qmesh setup`.

pip installs the wheels but not the shared libraries they load: VTK renders off-screen through
Mesa's EGL, Playwright's node binary needs libatomic, the browser tests drive Debian's chromium,
gmsh's wheel (the `peers` extra) links against X, GLU and OpenMP, and NGSolve's OpenBLAS (the
`fem-ngsolve` extra) against the GNU Fortran runtime. Without them the viewer's tests die with a
segfault rather than an error. Two modes, one for each of the README's set-up commands: `qmesh
setup` installs the groups whose Python package is installed, those only the tests need left
out, so the core alone needs nothing and the viewer only Mesa; `qmesh setup --test` installs
every group (the test suite renders, drives chromium, runs gmsh and NGSolve).

`setup()` asks dpkg which packages are missing (one `dpkg-query`, quick when all are there),
installs them with apt-get when it may (root, or sudo without a password), and otherwise prints
the exact command to run and returns 1.
"""

from __future__ import annotations

import ctypes.util
import importlib.util
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from typing import Callable, Sequence

from qmesh.errors import QmeshError


@dataclass(frozen=True)
class Group:
    """Debian packages needed when the Python module `module` is installed; `libraries` and
    `programs` are what they provide, looked for where there is no dpkg to ask. `tests_only`:
    only the test suite needs the group, never a user's `qmesh setup`."""

    name: str
    module: str
    packages: tuple[str, ...]
    why: str
    libraries: tuple[str, ...] = ()
    programs: tuple[str, ...] = ()
    tests_only: bool = False


GROUPS = (
    Group("rendering", "vtk", ("libegl1", "libgl1", "libgl1-mesa-dri"),
          "off-screen rendering by VTK through Mesa EGL and llvmpipe (viewer, widget)",
          libraries=("EGL", "GL")),
    Group("browser", "playwright", ("chromium", "libatomic1"),
          "the browser tests: Debian's chromium, driven by Playwright's node (needs libatomic)",
          libraries=("atomic",), programs=("chromium",), tests_only=True),
    Group("gmsh", "gmsh", ("libgl1", "libglu1-mesa", "libxcursor1", "libxft2", "libxinerama1",
                           "libxrender1", "libfontconfig1", "libgomp1"),
          "the peers extra's gmsh wheel (BAMG): X, GL, GLU and OpenMP libraries",
          libraries=("GL", "GLU", "Xcursor", "Xft", "Xinerama", "Xrender", "fontconfig", "gomp")),
    Group("ngsolve", "ngsolve", ("libgfortran5",),
          "NGSolve's OpenBLAS (the fem-ngsolve extra): the GNU Fortran runtime it links",
          libraries=("gfortran",)),
)
"""Every group of system packages, with the module whose presence makes it needed; the test suite
needs them all."""

APT_INSTALL = ("apt-get", "install", "-y", "-q", "--no-install-recommends")


def module_installed(name: str) -> bool:
    """Whether the Python module `name` can be imported here (found, not imported)."""
    return importlib.util.find_spec(name) is not None


def needed_groups(everything: bool = False, groups: Sequence[Group] = GROUPS,
                  tests: bool = False) -> list[Group]:
    """The groups to install: every one with `everything` or `tests` (the test suite needs them
    all); otherwise those whose Python module is installed, less the ones only the tests need."""
    if everything or tests:
        return list(groups)
    return [g for g in groups if not g.tests_only and module_installed(g.module)]


def installed(packages: Sequence[str], run: Callable = subprocess.run) -> set[str] | None:
    """The packages dpkg reports as installed (one dpkg-query call); None without dpkg."""
    if not packages:
        return set()
    try:
        out = run(["dpkg-query", "-W", "-f=${Package} ${db:Status-Status}\\n", *packages],
                  capture_output=True, text=True, check=False).stdout
    except FileNotFoundError:
        return None
    return {line.split()[0] for line in out.splitlines()
            if len(line.split()) == 2 and line.split()[1] == "installed"}


def missing(groups: Sequence[Group], run: Callable = subprocess.run) -> list[str] | None:
    """Packages of `groups` that are not installed, each once, in the groups' order; None
    when there is no dpkg to ask."""
    wanted = list(dict.fromkeys(p for g in groups for p in g.packages))
    have = installed(wanted, run)
    return None if have is None else [p for p in wanted if p not in have]


def not_found(groups: Sequence[Group]) -> list[str]:
    """Libraries (as lib<name>) and programs of `groups` that cannot be found on this system."""
    find, which = ctypes.util.find_library, shutil.which
    libs = dict.fromkeys(lib for g in groups for lib in g.libraries)
    progs = dict.fromkeys(p for g in groups for p in g.programs)
    return [f"lib{lib}" for lib in libs if find(lib) is None] + [p for p in progs if which(p) is None]


def may_use_apt(run: Callable = subprocess.run) -> list[str] | None:
    """The command prefix that runs apt-get as root ([] as root, ["sudo", "-n"]), or None."""
    if os.geteuid() == 0:
        return []
    if shutil.which("sudo") and run(["sudo", "-n", "true"], capture_output=True,
                                    check=False).returncode == 0:
        return ["sudo", "-n"]
    return None


def manual_command(packages: Sequence[str]) -> str:
    """The command line a user runs when qmesh may not run apt-get itself."""
    return "sudo apt-get update && sudo " + " ".join(APT_INSTALL + tuple(packages))


def setup(check_only: bool = False, everything: bool = False, run: Callable = subprocess.run,
          prefix: Callable = may_use_apt, out=None, tests: bool = False) -> int:
    """Make sure the system packages for the installed extras (with `tests`: for the test
    suite) are there; the exit status.

    0: all present (or just installed); 1: some are missing and were not installed (the
    command to run is printed), or apt-get failed.
    """
    out = out or sys.stdout
    groups = needed_groups(everything, tests=tests)
    if not groups:
        print("qmesh setup: no extra needs system packages", file=out)
        return 0
    lack = missing(groups, run)
    if lack is None:
        absent = not_found(groups)
        if not absent:
            print("qmesh setup: no dpkg here; the libraries and programs the extras need were found",
                  file=out)
            return 0
        names = " ".join(dict.fromkeys(p for g in groups for p in g.packages))
        print(f"qmesh setup: no dpkg here, and {' '.join(absent)} not found; install your "
              f"system's equivalents of the Debian packages {names}", file=out)
        return 1
    what = ", ".join(g.name for g in groups)
    if not lack:
        print(f"qmesh setup: system packages for {what} are installed", file=out)
        return 0
    pre = None if check_only else prefix(run)
    if pre is None:
        reason = "checked only" if check_only else "not root and no password-less sudo"
        print(f"qmesh setup: missing system packages ({reason}): {' '.join(lack)}\n"
              f"run: {manual_command(lack)}", file=out)
        return 1
    print(f"qmesh setup: installing {' '.join(lack)}", file=out, flush=True)
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    if pre:                                  # sudo resets the environment: pass it through env
        pre = pre + ["env", "DEBIAN_FRONTEND=noninteractive"]
    for cmd in (["apt-get", "update", "-q"], list(APT_INSTALL) + lack):
        status = run(pre + cmd, env=env, check=False).returncode
        if status != 0:
            print(f"qmesh setup: `{' '.join(pre + cmd)}` failed with exit status {status}", file=out)
            return 1
    still = missing(groups, run)
    if still:
        print(f"qmesh setup: still missing after apt-get: {' '.join(still)}", file=out)
        return 1
    return 0


def require(name: str, run: Callable = subprocess.run) -> None:
    """Raise QmeshError naming the missing Debian packages of group `name` (e.g. "rendering"),
    before code that would crash without them (VTK segfaults without EGL). Silent where dpkg
    cannot tell (not Debian) or all are there; one dpkg-query call."""
    group = {g.name: g for g in GROUPS}.get(name)
    if group is None:
        raise QmeshError(f"name must be one of {sorted(g.name for g in GROUPS)}, got {name!r}")
    lack = missing([group], run)
    if lack:
        raise QmeshError(f"{group.why} needs the Debian packages {' '.join(lack)}, which are not "
                         f"installed; run `qmesh setup` (as root) or: {manual_command(lack)}")
