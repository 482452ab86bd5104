"""``rigval docs [TOPIC]``: print a documentation page (scene, mechanism, formats, ...).

The pages of ``docs/`` are installed with rigval (package ``rigval.docs``), so error hints that
name a page (``see docs/scene.md``) can be followed from an installed package:
``rigval docs scene``. Without a topic the command lists the pages with their titles.
"""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from rigval.validation.commands.common import add_command

__all__ = ["add_parser", "pages", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``docs`` subcommand."""
    parser = add_command(
        subparsers, run, "docs",
        help="print a documentation page (scene, mechanism, formats, ...)",
        description="Print one of rigval's documentation pages (Markdown), e.g. 'rigval docs "
                    "scene' for every key of a scene file. Without TOPIC: list the pages.",
        exit_codes="0 ok, 2 unknown topic.")
    parser.add_argument("topic", nargs="?", metavar="TOPIC",
                        help="page name, e.g. scene, mechanism, formats (with or without .md)")
    parser.add_argument("--path", action="store_true",
                        help="print where the page is installed instead of its text")


def _folder() -> Traversable:
    """Return the installed pages, or the source tree's ``docs/`` (editable installs)."""
    try:
        return resources.files("rigval.docs")
    except ModuleNotFoundError:  # an editable install maps only the code packages
        return Path(__file__).resolve().parents[2] / "docs"


def pages() -> dict[str, Traversable]:
    """Return the documentation pages by topic (file name without ``.md``), sorted."""
    found = {entry.name.removesuffix(".md"): entry for entry in _folder().iterdir()
             if entry.name.endswith(".md")}
    return dict(sorted(found.items()))


def _title(page: Traversable) -> str:
    """Return the first heading of a page."""
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("# "):
            return line[2:].strip()
    return ""


def run(args: argparse.Namespace) -> int:
    """Print the page (or the list of pages); return the exit code."""
    from rigval.acquisition.errors import ConfigError

    found = pages()
    if args.topic is None:
        width = max(map(len, found), default=0)
        for topic, page in found.items():
            print(f"{topic:<{width}}  {_title(page)}")
        return 0
    topic = Path(args.topic).name.removesuffix(".md")
    if topic not in found:
        raise ConfigError(f"no documentation page {args.topic!r}",
                          where={"option": "TOPIC"},
                          hint=f"give one of: {', '.join(found)}")
    page = found[topic]
    if args.path:
        print(page)
    else:
        sys.stdout.write(page.read_text(encoding="utf-8"))
    return 0
