"""Compiled hot loops: the few kernels numpy cannot vectorise, compiled by numba ahead of their first use.

Kernels are written with ``@numba.njit(SIGNATURE, cache=True)``: an explicit signature compiles at import, and the
cache keeps the machine code beside the module, so only the first import on a machine pays the compile. The
install step (``make install``) runs ``python -m mrs_nav.jit``, which imports every module listed in
``KERNEL_MODULES``; a node or a test then never stalls seconds on its first scan or plan.

Numba keys a module's cache on that module's source file alone, while a kernel that calls a kernel of another
module keeps its own compiled copy of that callee: after a change to the callee's module alone, the caller's cache
would still run the old callee (seen with the tree planners' collision check, called from three modules). So
:func:`warm` first drops every kernel module's cache when any kernel module's source differs from the last warm's.
"""

from __future__ import annotations

import hashlib
import importlib
from importlib.util import find_spec
from pathlib import Path

# Modules holding numba kernels, by name: importing them compiles (or loads) their kernels.
KERNEL_MODULES: tuple[str, ...] = (
    "mrs_nav.maps.route_kernels",
    "mrs_nav.sim.laser",
    "mrs_nav.slam.grid_kernels",
    "mrs_nav.slam.matcher_kernels",
    "mrs_nav.trees.guide_kernels",
    "mrs_nav.trees.kernels",
    "mrs_nav.trees.primitives",
    "mrs_nav.trees.search_kernels",
)
# The digest of the kernel sources the caches were last warmed from.
STAMP = Path(__file__).parent / "__pycache__" / "kernel-sources.sha256"


def kernel_sources() -> list[Path]:
    """The source files of ``KERNEL_MODULES``."""
    out = []
    for name in KERNEL_MODULES:
        spec = find_spec(name)
        if spec is None or spec.origin is None:
            raise ImportError(f"kernel module {name} not found")
        out.append(Path(spec.origin))
    return out


def sources_digest(sources: list[Path]) -> str:
    """SHA-256 over the names and contents of ``sources``."""
    digest = hashlib.sha256()
    for path in sources:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def drop_stale_caches(sources: list[Path], stamp: Path) -> bool:
    """Delete the numba caches (``__pycache__/<module>.*.nbi`` and ``.nbc``) of every file of ``sources`` when
    their digest differs from the one in ``stamp`` (or there is none); True when it did."""
    try:
        if stamp.read_text(encoding="utf-8").strip() == sources_digest(sources):
            return False
    except OSError:
        pass
    for path in sources:
        for cached in (path.parent / "__pycache__").glob(f"{path.stem}.*.nb[ci]"):
            cached.unlink(missing_ok=True)
    return True


def warm() -> None:
    """Compile, or load from the cache, every kernel of ``KERNEL_MODULES``, after dropping stale caches."""
    sources = kernel_sources()
    drop_stale_caches(sources, STAMP)
    for name in KERNEL_MODULES:
        importlib.import_module(name)
    # A torn or unwritten stamp only costs a compile at the next warm. (Where __pycache__ is read-only, numba keeps
    # its caches in a user-wide folder that this does not clear: noted, not handled.)
    try:
        STAMP.parent.mkdir(parents=True, exist_ok=True)
        STAMP.write_text(sources_digest(sources) + "\n", encoding="utf-8")
    except OSError:
        pass


if __name__ == "__main__":
    warm()
