"""The shared HTML page builder: escaping, tables, embedded figures, self-contained output."""

from __future__ import annotations

import base64
import re
from xml.etree import ElementTree

from matplotlib.figure import Figure

from rigval.validation.report.page import Link, Page, figure_data_uri, format_value


def _figure() -> Figure:
    fig = Figure(figsize=(2, 1.5))
    fig.add_subplot().plot([0, 1, 2], [1, 0, 1])
    return fig


def test_figure_is_embedded_as_a_decodable_png() -> None:
    uri = figure_data_uri(_figure(), dpi=50)
    assert uri.startswith("data:image/png;base64,")
    png = base64.b64decode(uri.split(",", 1)[1])
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    width = int.from_bytes(png[16:20], "big")
    assert width == 100  # 2 in x 50 dpi


def test_page_escapes_text_and_links_sections() -> None:
    page = Page("a <b> & c")
    anchor = page.section("Channel <acc1>")
    page.paragraph("x < y")
    page.table([{"name": "acc1", "rating": 0.91234567, "status": "pass"},
                {"name": "tor1", "rating": float("nan"), "status": "fail"}], caption="metrics")
    page.figure(_figure(), caption="overlay", fmt="svg")
    text = page.render()
    assert "<b>" not in text.split("<body>")[1].split("</header>")[0]
    assert "Channel &lt;acc1&gt;" in text and "x &lt; y" in text
    assert f'href="#{anchor}"' in text and f'id="{anchor}"' in text
    assert ">0.9123<" in text and '"text ok">pass<' in text and '"text bad">fail<' in text
    assert "<svg" in text and "<?xml" not in text
    assert not re.search(r'(src|href)="(https?:|file:|/)', text)  # nothing outside the file


def test_inline_svgs_are_well_formed_with_ids_unique_on_the_page() -> None:
    page = Page("t", figure_format="svg")
    for caption in ("first", "second"):  # the same figure twice: the same ids without prefixes
        page.figure(_figure(), caption=caption)
    text = page.render()
    svgs = re.findall(r"<svg .*?</svg>", text, re.S)
    assert len(svgs) == 2 and "<img" not in text
    ids = re.findall(r'\bid="([^"]+)"', text)
    assert len(ids) == len(set(ids))
    for svg in svgs:
        root = ElementTree.fromstring(svg)  # well-formed XML
        assert root.get("aria-label") in ("first", "second")
        own = {element.get("id") for element in root.iter()} - {None}
        references = re.findall(r'(?:href="#|url\(#)([^")]+)', svg)
        assert references and set(references) <= own  # clip paths, markers: in the same SVG
        # text stays text: the tick labels of the y axis (0.0 to 1.0)
        texts = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text")]
        assert "0.0" in texts and "1.0" in texts


def test_table_link_cells_are_escaped_anchors() -> None:
    page = Page("t")
    page.table([{"run": Link("a<b", 'r"1/report.html'), "value": 0.5},
                {"run": "plain", "value": 1}])
    html = page.render()
    assert '<td class="text"><a href="r&quot;1/report.html">a&lt;b</a></td>' in html
    assert '<td class="text">plain</td>' in html and "<td>0.5</td>" in html


def test_duplicate_headings_get_unique_ids() -> None:
    page = Page("t")
    assert page.section("Result") != page.section("Result")


def test_format_value() -> None:
    assert format_value(None) == "–"
    assert format_value(True) == "yes"
    assert format_value(3) == "3"
    assert format_value(1234567.0, 3) == "1.23e+06"
    assert format_value(float("nan")) == "–"


def test_written_page_equals_the_rendered_text(tmp_path) -> None:
    """The page written part by part is the whole rendered text, as UTF-8."""
    page = Page("Sommer \u00e9t\u00e9 \u2013 run", subtitle="one")
    page.section("first")
    page.paragraph("\u03c6_F in \u00b0")
    page.figure(_figure(), caption="overlay", fmt="svg")
    page.raw("<p>last</p>")
    path = page.write(tmp_path / "page.html")
    stamp = re.compile(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC")
    assert stamp.sub("T", path.read_bytes().decode("utf-8")) == stamp.sub("T", page.render())
    assert Page("empty").write(tmp_path / "empty.html").read_text(encoding="utf-8").endswith(
        "</html>\n")
