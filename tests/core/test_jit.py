"""Kernel caches are dropped when any kernel source changes: a caller's cache keeps its own copy of a callee that
lives in another module, which numba would not recompile after a change to that module alone."""

from __future__ import annotations

from pathlib import Path

from mrs_nav.jit import KERNEL_MODULES, drop_stale_caches, kernel_sources, sources_digest


def _module(folder: Path, name: str, source: str) -> tuple[Path, Path]:
    path = folder / f"{name}.py"
    path.write_text(source)
    cache = folder / "__pycache__" / f"{name}.kernel-10.py311.1.nbc"
    cache.parent.mkdir(exist_ok=True)
    cache.write_bytes(b"machine code")
    (folder / "__pycache__" / f"{name}.kernel-10.py311.nbi").write_bytes(b"index")
    return path, cache


def test_every_cache_is_dropped_when_one_kernel_source_changes_and_kept_otherwise(tmp_path: Path) -> None:
    callee, callee_cache = _module(tmp_path, "callee", "def kernel(): return 1\n")
    caller, caller_cache = _module(tmp_path, "caller", "from callee import kernel\n")
    other = tmp_path / "__pycache__" / "unrelated.cpython-311.pyc"
    other.write_bytes(b"bytecode")
    stamp = tmp_path / "stamp"
    assert drop_stale_caches([callee, caller], stamp)  # no stamp yet: nothing is known to be fresh
    assert not caller_cache.exists()
    assert not callee_cache.exists()
    assert other.exists()
    stamp.write_text(sources_digest([callee, caller]))
    _, caller_cache = _module(tmp_path, "caller", "from callee import kernel\n")
    assert not drop_stale_caches([callee, caller], stamp)
    assert caller_cache.exists()
    callee.write_text("def kernel(): return 2\n")  # only the callee's module changes
    assert drop_stale_caches([callee, caller], stamp)
    assert not caller_cache.exists()
    assert not list((tmp_path / "__pycache__").glob("*.nbi"))


def test_every_module_with_a_compiled_kernel_is_listed() -> None:
    listed = {path.resolve() for path in kernel_sources()}
    package = Path(__file__).resolve().parents[2] / "src" / "mrs_nav"
    compiled = {path.resolve() for path in package.rglob("*.py") if "numba.njit" in path.read_text()}
    compiled.discard((package / "jit.py").resolve())
    assert compiled == listed, sorted(str(p) for p in compiled ^ listed)
    assert len(KERNEL_MODULES) == len(listed)
