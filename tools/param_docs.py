#!/usr/bin/env python3
"""Write or check each node's parameter table in docs/nodes/<node>.md from config/<node>.yaml.

    python tools/param_docs.py --write   # rewrite the tables (only between the markers; the page stays)
    python tools/param_docs.py --check   # exit 1, naming each page whose table differs from its YAML

The table (name, type, default, unit, range, meaning) comes from the ``# [unit] (range) meaning`` comment of each
parameter line (format: mrs_nav.config_files). It sits between the BEGIN and END marker lines; a page without
them gets a title and the block.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(CHECKOUT / "src"))  # document this checkout's files, whatever else is installed

from mrs_nav.config_files import NODES, ParameterDoc, parameter_docs  # noqa: E402
from mrs_nav.errors import MrsNavError  # noqa: E402

DOCS_DIR = CHECKOUT / "docs" / "nodes"
END = "<!-- END parameters -->"
HEADER = ("Parameter", "Type", "Default", "Unit", "Range", "Meaning")


def begin_marker(node: str) -> str:
    return f"<!-- BEGIN parameters (generated from config/{node}.yaml by tools/param_docs.py; do not edit) -->"


def format_default(value: object) -> str:
    """The default as YAML would read it back: true, 0.2, "" , [tcp/...], NaN."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    if isinstance(value, str):
        return value if value else '""'
    if isinstance(value, list | dict):
        return json.dumps(value)
    return repr(value)


def _cell(text: str, code: bool = False) -> str:
    text = text.replace("|", "\\|")
    return f"`{text}`" if code and text else text


def table(docs: list[ParameterDoc]) -> list[str]:
    """The Markdown table of ``docs``, one line per parameter."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    for doc in docs:
        cells = (
            _cell(f"~{doc.name}", code=True),
            doc.type,
            _cell(format_default(doc.default), code=True),
            _cell(doc.unit),
            _cell(doc.range),
            _cell(doc.meaning),
        )
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def render(node: str, page: str) -> str:
    """``page`` with its parameter block replaced by the table from the node's YAML."""
    block = [begin_marker(node), "", *table(parameter_docs(node)), "", END]
    lines = page.splitlines()
    begin = next((i for i, line in enumerate(lines) if line.startswith("<!-- BEGIN parameters")), None)
    if begin is None:
        head = lines or [f"# {node}"]
        return "\n".join([*head, "", *block]) + "\n"
    end = next((i for i in range(begin, len(lines)) if lines[i] == END), None)
    if end is None:
        raise MrsNavError(f"docs/nodes/{node}.md: {lines[begin]!r} has no {END!r} after it")
    return "\n".join([*lines[:begin], *block, *lines[end + 1 :]]) + "\n"


def stale_pages() -> list[str]:
    """The node pages whose table is missing or differs from the YAML."""
    stale = []
    for node in NODES:
        path = DOCS_DIR / f"{node}.md"
        page = path.read_text(encoding="utf-8") if path.is_file() else ""
        if not page or render(node, page) != page:
            stale.append(str(path.relative_to(CHECKOUT)))
    return stale


def write() -> None:
    DOCS_DIR.mkdir(parents=True, exist_ok=True)
    for node in NODES:
        path = DOCS_DIR / f"{node}.md"
        page = path.read_text(encoding="utf-8") if path.is_file() else ""
        rendered = render(node, page)
        if rendered != page:
            path.write_text(rendered, encoding="utf-8")
            print(f"wrote {path.relative_to(CHECKOUT)}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    action = parser.add_mutually_exclusive_group(required=True)
    action.add_argument("--write", action="store_true", help="rewrite the parameter tables")
    action.add_argument("--check", action="store_true", help="fail if a table differs from its YAML")
    args = parser.parse_args(argv)
    try:
        if args.write:
            write()
            return 0
        stale = stale_pages()
    except MrsNavError as err:
        print(f"ERROR: {err}", file=sys.stderr)
        return 1
    for page in stale:
        print(f"ERROR: {page}: parameter table out of date; run python tools/param_docs.py --write", file=sys.stderr)
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
