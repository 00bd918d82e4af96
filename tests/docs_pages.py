"""Reading the Markdown docs as GitHub renders them: pages, headings and their anchors, links, shell commands.

Used by ``tests/test_docs.py``; plain functions over text so that a failing check can name the page and line.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[1]
SHELL_LANGUAGES = {"sh", "bash", "console", "shell"}

_FENCE = re.compile(r"^\s*(```+|~~~+)\s*([\w+-]*)")
_HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
_LINK = re.compile(r"(?<!!)\[(?:[^\[\]]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
_INLINE_CODE = re.compile(r"(`+)(?:(?!\1).)+\1")


def pages() -> list[Path]:
    """Every Markdown page the docs checks cover: the README, docs/ and the benchmark results."""
    return [CHECKOUT / "README.md", *sorted((CHECKOUT / "docs").rglob("*.md")), CHECKOUT / "bench" / "RESULTS.md"]


@dataclass(frozen=True)
class Line:
    number: int
    text: str


def prose_lines(text: str) -> Iterator[Line]:
    """The lines outside fenced code blocks."""
    fence = ""
    for number, line in enumerate(text.split("\n"), 1):
        match = _FENCE.match(line)
        if match and (not fence or (match[1].startswith(fence[0]) and len(match[1]) >= len(fence))):
            fence = "" if fence else match[1]
            continue
        if not fence:
            yield Line(number, line)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: the rendered text lower-cased, punctuation dropped, spaces made hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link renders as its text
    text = re.sub(r"<[^>]+>", "", text).replace("`", "").lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(text: str) -> set[str]:
    """Every heading's anchor in a page; repeated headings get GitHub's -1, -2 suffixes."""
    seen: dict[str, int] = {}
    found = set()
    for line in prose_lines(text):
        match = _HEADING.match(line.text)
        if not match:
            continue
        base = slug(match[2])
        count = seen.get(base, 0)
        seen[base] = count + 1
        found.add(base if count == 0 else f"{base}-{count}")
    return found


def links(text: str) -> Iterator[tuple[int, str]]:
    """(line, target) of every Markdown link outside code (inline code blanked out: a link in code is no link)."""
    for line in prose_lines(text):
        for match in _LINK.finditer(_INLINE_CODE.sub(lambda m: " " * len(m[0]), line.text)):
            yield line.number, match[1]


def is_external(target: str) -> bool:
    return re.match(r"^[a-z][a-z0-9+.-]*:", target) is not None


@dataclass(frozen=True)
class Command:
    page: str  # path relative to the checkout
    line: int
    text: str  # one logical command: continuation lines joined, comments dropped, blanks collapsed


def _strip_comment(line: str) -> str:
    """The line without a shell comment (a ``#`` at a word start outside quotes)."""
    quote = ""
    for i, char in enumerate(line):
        if quote:
            quote = "" if char == quote else quote
        elif char in "'\"":
            quote = char
        elif char == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i]
        elif char == "\\" and i + 1 < len(line):
            continue
    return line


def _normalise(command: str) -> str:
    return "\n".join(" ".join(part.split()) for part in command.split("\n") if part.strip())


def shell_commands(path: Path) -> list[Command]:
    """The commands of a page's ```sh, ```bash, ```shell and ```console blocks (in console blocks only the lines
    after a ``$`` prompt). A line ending in a backslash continues on the next; a ``for``/``while``/``if`` compound
    runs to its ``done``/``fi`` and is one command whose lines are kept."""
    name = str(path.relative_to(CHECKOUT))
    found: list[Command] = []
    language, fence = "", ""
    pending: list[str] = []
    start = 0
    depth = 0
    for number, raw in enumerate(path.read_text(encoding="utf-8").split("\n"), 1):
        match = _FENCE.match(raw)
        if match and (not fence or (match[1].startswith(fence[0]) and len(match[1]) >= len(fence))):
            fence, language = ("", "") if fence else (match[1], match[2].lower())
            continue
        if language not in SHELL_LANGUAGES:
            continue
        line = raw.strip()
        if language == "console":
            if not line.startswith("$ ") and not pending:
                continue
            line = line.removeprefix("$ ")
        line = _strip_comment(line).rstrip()
        if not line and not pending:
            continue
        if not pending:
            start = number
        words = line.replace(";", " ; ").split()
        depth += bool(words) and words[0] in ("for", "while", "until", "if")
        depth -= sum(w in ("done", "fi") for w in words)
        continued = line.endswith("\\")
        pending.append(line.removesuffix("\\").rstrip() + ("" if continued else "\n"))
        if not continued and depth <= 0:
            found.append(Command(name, start, _normalise(" ".join(pending).replace("\n ", "\n"))))
            pending, depth = [], 0
    return found
