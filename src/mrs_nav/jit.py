"""Compiled hot loops: the few kernels numpy cannot vectorise, compiled by numba ahead of their first use.

Kernels are written with ``@numba.njit(SIGNATURE, cache=True)``: an explicit signature compiles at import, and the
cache keeps the machine code beside the module, so only the first import on a machine pays the compile. The
install step (``make install``) runs ``python -m mrs_nav.jit``, which imports every module listed in
``KERNEL_MODULES``; a node or a test then never stalls seconds on its first scan or plan.
"""

from __future__ import annotations

import importlib

# Modules holding numba kernels, by name: importing them compiles (or loads) their kernels.
KERNEL_MODULES: tuple[str, ...] = (
    "mrs_nav.maps.route_kernels",
    "mrs_nav.sim.laser",
    "mrs_nav.slam.grid_kernels",
    "mrs_nav.slam.matcher_kernels",
    "mrs_nav.trees.guide_kernels",
    "mrs_nav.trees.kernels",
)


def warm() -> None:
    """Compile, or load from the cache, every kernel of ``KERNEL_MODULES``."""
    for name in KERNEL_MODULES:
        importlib.import_module(name)


if __name__ == "__main__":
    warm()
