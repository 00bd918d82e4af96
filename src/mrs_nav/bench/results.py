"""Writing benchmark results into ``bench/RESULTS.md`` with the date and the machine.

Each benchmark owns one section, delimited by HTML comments, so re-running one benchmark replaces its own
section and leaves the others as they were measured.
"""

from __future__ import annotations

import datetime as dt
import os
import platform
import re
from pathlib import Path

from mrs_nav.atomic_write import write_text
from mrs_nav.resources import CHECKOUT
from mrs_nav.tables import markdown_table
from mrs_nav.textfiles import DESCRIPTION_LIMIT, check_writable, read_text

# markdown_table lives in mrs_nav.tables (batch replays use it too); benchmarks may take it from here.
__all__ = ["default_results_path", "machine_description", "markdown_table", "results_path", "write_section"]

_HEADER = (
    "# mrs_nav benchmark results\n\n"
    "Written by `mrs-nav bench NAME`; each section is replaced when its benchmark runs again.\n"
)


def machine_description() -> str:
    """One line naming the machine: CPU model, cores, memory, OS and Python."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kib = int(Path("/proc/meminfo").read_text().split()[1])
        mem = f", {kib / 1024 / 1024:.0f} GiB RAM"
    except (OSError, ValueError, IndexError):
        pass
    system = f"{platform.system()} {platform.release()}"
    return f"{cpu}, {os.cpu_count()} cores{mem}, {system}, Python {platform.python_version()}"


def default_results_path() -> Path:
    """``bench/RESULTS.md`` of the source checkout when running from one, else of the current folder."""
    if (CHECKOUT / "package.xml").is_file() and (CHECKOUT / "bench").is_dir():
        return CHECKOUT / "bench" / "RESULTS.md"
    return Path.cwd() / "bench" / "RESULTS.md"


def results_path(path: Path | None = None) -> Path:
    """The results file to update (``path``, else :func:`default_results_path`), checked before a benchmark
    runs: a folder, a device, an unreadable file or a folder that cannot be written is refused now, with one
    line, not after the measuring."""
    path = path or default_results_path()
    check_writable(path, "--results")
    _previous(path)
    return path


def _previous(path: Path) -> str:
    """The results written so far (a regular file read as text, never a device read without end)."""
    return read_text(path, DESCRIPTION_LIMIT, "benchmark results") if path.exists() else _HEADER


def write_section(name: str, body: str, path: Path | None = None) -> Path:
    """Replace (or append) the section of benchmark ``name`` with ``body``, stamped with date and machine."""
    path = path or default_results_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    text = _previous(path)
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    section = (
        f"<!-- bench:{name} -->\n## {name}\n\n"
        f"Measured {stamp} on {machine_description()}.\n\n{body.strip()}\n<!-- /bench:{name} -->\n"
    )
    pattern = re.compile(rf"<!-- bench:{re.escape(name)} -->.*?<!-- /bench:{re.escape(name)} -->\n", re.S)
    text = pattern.sub(lambda _: section, text) if pattern.search(text) else text.rstrip("\n") + "\n\n" + section
    return write_text(path, text, "benchmark results")
