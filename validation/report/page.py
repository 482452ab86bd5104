"""A small builder for self-contained HTML report pages.

A :class:`Page` collects sections, paragraphs, key-value lists, tables and matplotlib figures and
renders them into one HTML file that opens offline: the style sheet (``page.css``, a data file of
this package) is inlined and every figure is embedded as a base64 PNG (``data:`` URI) or as
inline SVG. Text is always escaped; only :meth:`Page.raw` inserts markup verbatim.

Example
-------
>>> from matplotlib.figure import Figure
>>> page = Page("rigval report", subtitle="run 3")
>>> page.section("Summary")
>>> page.facts({"scene": "run3.toml", "result": "passed"})
>>> fig = Figure(figsize=(4, 3)); _ = fig.add_subplot().plot([0, 1], [0, 1])
>>> page.figure(fig, caption="a line")
>>> html_text = page.render()
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import io
import math
import numbers
import re
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from rigval.acquisition.outputs import atomic_output

if TYPE_CHECKING:  # a page's text needs no matplotlib: a process that only places drawn
    from matplotlib.figure import Figure  # figures (rigval.validation.report.drawing) skips it

__all__ = ["STATUS_CLASSES", "STYLE_SHEET", "Link", "Page", "escape", "figure_data_uri",
           "figure_svg", "format_value", "prefix_ids", "style_sheet", "svg_text"]

#: CSS class per status word; :meth:`Page.table` colours cells whose text is one of these.
STATUS_CLASSES = {"pass": "ok", "passed": "ok", "ok": "ok", "fail": "bad", "failed": "bad",
                  "error": "bad", "inconclusive": "warn", "warning": "warn"}

#: The style sheet, a data file of this package (inlined into every page).
STYLE_SHEET = "page.css"


@dataclass(frozen=True)
class Link:
    """A table cell that links to another page (:meth:`Page.table` renders it as ``<a>``).

    Parameters
    ----------
    text : str
        What the cell shows (escaped).
    href : str
        The target, usually relative to the page (``"run_0p8/report.html"``; escaped).
    """

    text: str
    href: str


@cache
def style_sheet() -> str:
    """Return the pages' CSS, read once from the package data file :data:`STYLE_SHEET`."""
    return resources.files(__package__).joinpath(STYLE_SHEET).read_text(encoding="utf-8")


def escape(text: Any) -> str:
    """Return ``str(text)`` with ``&``, ``<``, ``>`` and quotes escaped for HTML."""
    return html.escape(str(text), quote=True)


def format_value(value: Any, digits: int = 4) -> str:
    """Return a table cell's text: floats with ``digits`` significant digits, NaN as a dash.

    Parameters
    ----------
    value : object
        The value; bools print as ``yes``/``no``, None as a dash.
    digits : int
        Significant digits for real numbers.
    """
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        number = float(value)
        if math.isnan(number):
            return "–"
        return f"{number:.{digits}g}"
    return str(value)


def figure_data_uri(fig: Figure, *, dpi: float = 96) -> str:
    """Return a figure as a ``data:image/png;base64,...`` URI.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (built without pyplot).
    dpi : float
        Resolution in dots per inch.
    """
    buffer = io.BytesIO()
    # zlib level 1: a third less encoding time than the default 6 for about 15 % larger files
    fig.savefig(buffer, format="png", dpi=dpi, pil_kwargs={"compress_level": 1})
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def figure_svg(fig: Figure, *, prefix: str = "figure") -> str:
    """Return a figure as an inline ``<svg>`` element (XML prolog and DOCTYPE removed).

    Text is written as ``<text>`` elements in the figure's font family (about half the
    drawing time of rendering its glyphs, and sharp at any zoom); a browser without that font
    uses the next of matplotlib's sans-serif fallbacks (Verdana, Arial, ...). No date is
    written, so the same figure gives the same text.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (built without pyplot).
    prefix : str
        Put before every element id and reference to one (``id="axes_1"`` becomes
        ``id="PREFIX-axes_1"``): give each figure of one page its own, so that the ids of
        several SVGs inlined in one HTML document do not collide.
    """
    return prefix_ids(svg_text(fig), prefix)


def svg_text(fig: Figure) -> str:
    """Return a figure as an ``<svg>`` element whose ids are not yet prefixed.

    The drawing of :func:`figure_svg`, which is :func:`prefix_ids` of this text; it is a plain
    string, so it can be drawn in another process (:mod:`rigval.validation.report.drawing`)
    and placed on a page later.
    """
    from matplotlib import rc_context

    buffer = io.StringIO()
    with rc_context({"svg.fonttype": "none", "svg.hashsalt": "rigval"}):
        fig.savefig(buffer, format="svg", metadata={"Date": None})
    text = buffer.getvalue()
    return text[text.index("<svg"):]


def prefix_ids(svg: str, prefix: str) -> str:
    """Return :func:`svg_text`'s element with ``prefix`` before every id and reference to one."""
    for start in (' id="', 'href="#', "url(#"):  # where matplotlib writes or refers to an id
        svg = svg.replace(start, f"{start}{prefix}-")
    return svg


def _slug(text: str, taken: set[str]) -> str:
    """Return a unique HTML id made from ``text``."""
    base = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "section"
    slug, n = base, 2
    while slug in taken:
        slug, n = f"{base}-{n}", n + 1
    taken.add(slug)
    return slug


class Page:
    """A self-contained HTML page built from sections, text, tables and figures.

    Parameters
    ----------
    title : str
        Page title (``<title>`` and the ``<h1>`` heading).
    subtitle : str, optional
        One line under the heading (run, date, status).
    contents : bool
        Whether to render a table of contents of the level-2 sections under the header.
    figure_format : {"png", "svg"}
        Default embedding format of :meth:`figure`.
    """

    def __init__(self, title: str, *, subtitle: str | None = None, contents: bool = True,
                 figure_format: Literal["png", "svg"] = "png") -> None:
        self.title = title
        self.figure_format = figure_format
        self.subtitle = subtitle
        self.contents = contents
        self._parts: list[str] = []
        self._toc: list[tuple[str, str]] = []
        self._ids: set[str] = set()

    def section(self, heading: str, *, level: Literal[2, 3, 4] = 2) -> str:
        """Start a section with a heading and return its HTML id (for links).

        Level-2 sections are listed in the table of contents.
        """
        anchor = _slug(heading, self._ids)
        self._parts.append(f'<h{level} id="{anchor}">{escape(heading)}</h{level}>')
        if level == 2:
            self._toc.append((anchor, heading))
        return anchor

    def paragraph(self, text: str, *, css_class: str | None = None) -> None:
        """Add a paragraph of plain (escaped) text, optionally with a CSS class (``ok``, ...)."""
        attr = f' class="{escape(css_class)}"' if css_class else ""
        self._parts.append(f"<p{attr}>{escape(text)}</p>")

    def items(self, texts: Iterable[str], *, css_class: str | None = None) -> None:
        """Add a bulleted list of plain (escaped) texts, optionally with a CSS class."""
        attr = f' class="{escape(css_class)}"' if css_class else ""
        self._parts.append(f"<ul{attr}>" + "".join(f"<li>{escape(text)}</li>" for text in texts)
                           + "</ul>")

    def facts(self, items: Mapping[str, Any]) -> None:
        """Add a key-value list (a ``<dl>``), values formatted by :func:`format_value`."""
        rows = "".join(f"<dt>{escape(k)}</dt><dd>{escape(format_value(v))}</dd>"
                       for k, v in items.items())
        self._parts.append(f"<dl>{rows}</dl>")

    def table(self, rows: Iterable[Mapping[str, Any]], *, columns: Sequence[str] | None = None,
              caption: str | None = None, digits: int = 4, collapsed: str | None = None) -> None:
        """Add a table with one row per mapping.

        Parameters
        ----------
        rows : iterable of mapping
            Row values by column name; missing entries print as a dash, a :class:`Link`
            as a link.
        columns : sequence of str, optional
            Column order; default the keys of the first row, then any new keys in order.
        caption : str, optional
            Table caption.
        digits : int
            Significant digits for real numbers.
        collapsed : str, optional
            Show the table folded under this summary line (a ``<details>`` element).
        """
        rows = list(rows)
        if columns is None:
            columns = list(dict.fromkeys(key for row in rows for key in row))
        head = "".join(f'<th class="text">{escape(c)}</th>' for c in columns)
        body = []
        for row in rows:
            cells = []
            for column in columns:
                value = row.get(column)
                if isinstance(value, Link):
                    cells.append(f'<td class="text"><a href="{escape(value.href)}">'
                                 f"{escape(value.text)}</a></td>")
                    continue
                text = format_value(value, digits)
                classes = []
                if not isinstance(value, numbers.Real) or isinstance(value, bool):
                    classes.append("text")
                status = STATUS_CLASSES.get(text.lower())
                if status:
                    classes.append(status)
                attr = f' class="{" ".join(classes)}"' if classes else ""
                cells.append(f"<td{attr}>{escape(text)}</td>")
            body.append("<tr>" + "".join(cells) + "</tr>")
        cap = f"<caption>{escape(caption)}</caption>" if caption else ""
        markup = (f"<table>{cap}<thead><tr>{head}</tr></thead>"
                  f"<tbody>{''.join(body)}</tbody></table>")
        markup = f'<div class="scroll">{markup}</div>'
        if collapsed is not None:
            markup = f"<details><summary>{escape(collapsed)}</summary>{markup}</details>"
        self._parts.append(markup)

    def wide_table(self, rows: Sequence[Mapping[str, Any]], *, key: Sequence[str],
                   caption: str | None = None, digits: int = 4, max_rows: int = 40) -> None:
        """Add a table too wide (or long) to read: the key columns, the whole table folded.

        Parameters
        ----------
        rows : sequence of mapping
            Row values by column name.
        key : sequence of str
            The columns shown first (those present in the rows, in this order).
        caption : str, optional
            Table caption.
        digits : int
            Significant digits for real numbers.
        max_rows : int
            A table with more rows is folded entirely (its key columns too).
        """
        columns = list(dict.fromkeys(k for row in rows for k in row))
        shown = [c for c in key if c in columns]
        rest = len(columns) - len(shown)
        long = len(rows) > max_rows
        if rest == 0 and long:
            self.table(rows, columns=columns, caption=caption, digits=digits,
                       collapsed=f"{caption or 'table'}: all {len(rows)} rows")
        elif rest > 0 or long:
            if shown:
                self.table(rows, columns=shown, caption=caption, digits=digits,
                           collapsed=f"{caption or 'table'}: the key columns of {len(rows)} "
                                     "rows" if long else None)
            self.table(rows, columns=columns, digits=digits,
                       collapsed=f"all {len(columns)} columns of {len(rows)} rows"
                                 + (f" ({caption})" if caption else ""))
        else:
            self.table(rows, columns=columns, caption=caption, digits=digits)

    def figure(self, fig: Figure | str, *, caption: str | None = None, alt: str | None = None,
               fmt: Literal["png", "svg"] | None = None, dpi: float = 96) -> None:
        """Embed a matplotlib figure (base64 PNG or inline SVG) with an optional caption.

        Parameters
        ----------
        fig : matplotlib.figure.Figure or str
            The figure; it is rendered now, so it may be discarded afterwards. A str is a
            figure already drawn by :func:`svg_text`, embedded as inline SVG.
        caption : str, optional
            Caption under the figure.
        alt : str, optional
            Alternative text of the image; default the caption.
        fmt : {"png", "svg"}, optional
            Embedding format; default the page's ``figure_format``. An SVG gets the alternative
            text as its ``aria-label``.
        dpi : float
            Resolution of PNG figures in dots per inch.
        """
        alt_text = escape(alt or caption or "figure")
        if isinstance(fig, str) or (fmt or self.figure_format) == "svg":
            drawn = fig if isinstance(fig, str) else svg_text(fig)
            svg = prefix_ids(drawn, f"figure-{len(self._parts)}")
            body = f'<svg role="img" aria-label="{alt_text}" {svg.removeprefix("<svg ")}'
        else:
            body = f'<img src="{figure_data_uri(fig, dpi=dpi)}" alt="{alt_text}">'
        cap = f"<figcaption>{escape(caption)}</figcaption>" if caption else ""
        self._parts.append(f"<figure>{body}{cap}</figure>")

    def preformatted(self, text: str) -> None:
        """Add a block of preformatted text (a scene file, a log), escaped."""
        self._parts.append(f"<pre>{escape(text)}</pre>")

    def raw(self, markup: str) -> None:
        """Add trusted HTML markup verbatim (never pass user text here unescaped)."""
        self._parts.append(markup)

    def render(self) -> str:
        """Return the whole page as an HTML5 document."""
        return "".join(self._pieces())

    def _pieces(self) -> Iterator[str]:
        """Yield the page's text in order: head, each part (newline-separated), footer."""
        sub = f'<p class="subtitle">{escape(self.subtitle)}</p>' if self.subtitle else ""
        toc = ""
        if self.contents and self._toc:
            items = "".join(f'<li><a href="#{a}">{escape(t)}</a></li>' for a, t in self._toc)
            toc = f"<nav><ol>{items}</ol></nav>"
        stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
        yield ('<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
               '<meta name="viewport" content="width=device-width, initial-scale=1">'
               f"<title>{escape(self.title)}</title><style>{style_sheet()}</style></head>"
               f"<body><main><header><h1>{escape(self.title)}</h1>{sub}</header>{toc}")
        for n, part in enumerate(self._parts):
            yield f"\n{part}" if n else part
        yield f"<footer>Written by rigval on {stamp}.</footer></main></body></html>\n"

    def write(self, path: str | Path) -> Path:
        """Render the page and write it to ``path`` (UTF-8, temporary name, then renamed).

        Written part by part, so that the page is never held whole as text and as bytes
        (a long run's page holds a hundred megabytes of figures).
        """
        final = Path(path)
        with atomic_output(final) as temporary, temporary.open("w", encoding="utf-8") as file:
            file.writelines(self._pieces())
        return final
