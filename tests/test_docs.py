"""The docs a newcomer reads stay true: links and anchors resolve, every page is reachable, every node script and
``mrs-nav`` subcommand has its page, and every command shown is run by a test (``tests/docs_commands.py``)."""

from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

from mrs_nav.cli.main import build_parser
from tests.docs_commands import COMMANDS, Covered, Parsed, Run
from tests.docs_pages import CHECKOUT, Command, anchors, is_external, links, pages, shell_commands

DOCS = CHECKOUT / "docs"
README_MAX_LINES = 250


def _resolve(page: Path, target: str) -> tuple[Path, str]:
    path, _, anchor = target.partition("#")
    return (page if not path else (page.parent / path).resolve()), anchor


def _broken_links(page: Path) -> list[str]:
    broken = []
    for line, target in links(page.read_text(encoding="utf-8")):
        if is_external(target):
            continue
        path, anchor = _resolve(page, target)
        where = f"{page.relative_to(CHECKOUT)}:{line}: ({target})"
        if not path.exists():
            broken.append(f"{where} no such file")
        elif anchor and (path.suffix != ".md" or anchor not in anchors(path.read_text(encoding="utf-8"))):
            broken.append(f"{where} no heading with anchor #{anchor} in {path.relative_to(CHECKOUT)}")
    return broken


@pytest.mark.parametrize("page", pages(), ids=lambda p: str(p.relative_to(CHECKOUT)))
def test_every_relative_link_and_anchor_resolves(page: Path) -> None:
    assert _broken_links(page) == []


def test_every_docs_page_is_reachable_from_the_index() -> None:
    seen, todo = set(), [DOCS / "index.md"]
    while todo:
        page = todo.pop()
        if page in seen:
            continue
        seen.add(page)
        for _, target in links(page.read_text(encoding="utf-8")):
            path, _ = _resolve(page, target)
            if not is_external(target) and path.suffix == ".md" and path.is_relative_to(DOCS) and path.exists():
                todo.append(path)
    unreachable = sorted(str(p.relative_to(CHECKOUT)) for p in DOCS.rglob("*.md") if p.resolve() not in seen)
    assert unreachable == []


def test_every_node_script_has_a_page() -> None:
    scripts = sorted(p.name for p in (CHECKOUT / "scripts").iterdir() if p.is_file())
    assert scripts, "no node scripts found"
    assert [s for s in scripts if not (DOCS / "nodes" / f"{s}.md").is_file()] == []


def _subcommands(parser: argparse.ArgumentParser) -> list[str]:
    actions = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return sorted(name for action in actions for name in action.choices)


def test_every_mrs_nav_subcommand_has_a_page() -> None:
    subcommands = _subcommands(build_parser())
    assert len(subcommands) >= 8
    assert [s for s in subcommands if not (DOCS / "cli" / f"{s}.md").is_file()] == []


def test_readme_stays_short() -> None:
    lines = (CHECKOUT / "README.md").read_text(encoding="utf-8").count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines; move detail into docs/"


def test_each_node_with_a_config_has_one_generated_parameters_block() -> None:
    """The parameter table generated from config/<node>.yaml goes between these markers on the node's page."""
    for config in sorted((CHECKOUT / "config").glob("*.yaml")):
        text = (DOCS / "nodes" / f"{config.stem}.md").read_text(encoding="utf-8")
        begin = (
            f"<!-- BEGIN parameters (generated from config/{config.stem}.yaml by tools/param_docs.py; do not edit) -->"
        )
        assert text.count(begin) == 1, f"docs/nodes/{config.stem}.md: one '{begin}' line"
        assert text.count("<!-- END parameters -->") == 1, f"docs/nodes/{config.stem}.md: one END marker"
        assert text.index(begin) < text.index("<!-- END parameters -->")


def _documented_commands() -> list[Command]:
    return [command for page in pages() for command in shell_commands(page)]


def test_every_command_in_the_docs_is_listed_with_what_runs_it() -> None:
    unlisted = [f"{c.page}:{c.line}: {c.text}" for c in _documented_commands() if c.text not in COMMANDS]
    assert unlisted == [], "add each to tests/docs_commands.py (Run, Covered, Parsed or Manual)"


def test_every_listed_command_is_still_in_the_docs() -> None:
    shown = {c.text for c in _documented_commands()}
    assert sorted(set(COMMANDS) - shown) == []


def test_every_test_named_for_a_command_exists() -> None:
    missing = []
    for command, entry in COMMANDS.items():
        if isinstance(entry, Covered):
            file, _, function = entry.test.partition("::")
            path = CHECKOUT / file
            if not path.is_file() or not re.search(rf"^def {re.escape(function)}\(", path.read_text(), re.M):
                missing.append(f"{command}: {entry.test}")
    assert missing == []


@pytest.mark.parametrize("command", [c for c, e in COMMANDS.items() if isinstance(e, Parsed)])
def test_commands_not_run_are_accepted_by_the_parser(command: str) -> None:
    argv = [os.path.expandvars(os.path.expanduser(word)) for word in shlex.split(command)]
    assert argv[0] == "mrs-nav"
    build_parser((argv[1],)).parse_args(argv[1:])


def _scratch(tmp_path: Path) -> Path:
    """A folder like a checkout for the commands to run in: copies of worlds/ and maps/ (a command may rewrite a
    map) and the regression bags, read only."""
    for name in ("worlds", "maps"):
        shutil.copytree(CHECKOUT / name, tmp_path / name)
    (tmp_path / "tests" / "data").mkdir(parents=True)
    (tmp_path / "tests" / "data" / "bags").symlink_to(CHECKOUT / "tests" / "data" / "bags")
    return tmp_path


def _run_here_by_page() -> dict[str, list[Command]]:
    by_page: dict[str, list[Command]] = defaultdict(list)
    for command in _documented_commands():
        if isinstance(COMMANDS.get(command.text), Run):
            by_page[command.page].append(command)
    return dict(by_page)


@pytest.mark.parametrize("page", sorted(_run_here_by_page()))
def test_commands_run_here_succeed(page: str, tmp_path: Path) -> None:
    scratch = _scratch(tmp_path)
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(CHECKOUT / "src"), env.get("PYTHONPATH", "")]))
    env["MPLBACKEND"] = "Agg"
    for command in _run_here_by_page()[page]:
        entry = COMMANDS[command.text]
        assert isinstance(entry, Run)
        cwd = CHECKOUT if entry.cwd == "checkout" else scratch
        done = subprocess.run(
            ["bash", "-c", command.text], cwd=cwd, env=env, capture_output=True, text=True, timeout=600, check=False
        )
        assert done.returncode == 0, f"{command.page}:{command.line}: {command.text}\n{done.stderr[-2000:]}"
