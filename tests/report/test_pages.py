"""A case page built from its templates: its sections in a fixed order, and the same numbers in
its HTML and its Markdown."""

import html
import re

import pytest

from flexmbd.report import pages, tables
from flexmbd.report import templates as T

# every section a case page can have, in the order of the page (`pages.SECTIONS`); the shapes,
# stress field and animation sections are titled by their own modules
ORDER = [T.RUNS.title, T.DEFLECTION.title, "Deformed shape at chosen instants", "Animation", T.STRESS.title,
         "Stress on the surface", T.ANGLES.title, T.SPECTRA.title, T.FREQUENCY_MAP.title, T.MODES.title, T.ELASTICITY.title, T.TIMING.title,
         T.ACCURACY.title, T.CONVERGENCE.title, T.PROVENANCE.title]
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


@pytest.fixture(scope="module")
def report(cantilever_report):
    """The session's report of cantilever_step by analytic, fe-linear and pinocchio (conftest.py). Read only."""
    return cantilever_report


def sections_html(page: str) -> dict:
    """Section title -> its HTML, in the page's order."""
    parts = re.split(r"<h2>([^<]*)</h2>", page.split("</body>")[0])
    return {html.unescape(t): body for t, body in zip(parts[1::2], parts[2::2])}


def sections_md(page: str) -> dict:
    """Section title -> its Markdown, in the page's order."""
    parts = re.split(r"^## (.*)$", page, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2]))


def table_numbers_html(body: str) -> list:
    """The numbers in a section's HTML tables, cell by cell, in the order written."""
    cells = re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", body, flags=re.S)
    return [n for c in cells for n in NUMBER.findall(html.unescape(re.sub(r"<[^>]+>", "", c)))]


def table_numbers_md(body: str) -> list:
    """The numbers in a section's Markdown tables (their header and body rows), in the order written."""
    rows = [line for line in body.splitlines() if line.startswith("|") and not re.fullmatch(r"\|(---\|)+", line)]
    return [n for line in rows for n in NUMBER.findall(line)]


def test_sections_come_in_a_fixed_order(report):
    """The page's sections, the same in HTML and Markdown, are those of cantilever_step in the page's
    fixed order: built in order, each after the one before, whatever the case has."""
    page = (report / "cantilever_step" / "index.html").read_text()
    md = (report / "cantilever_step" / "index.md").read_text()
    titles = list(sections_html(page))
    assert titles == list(sections_md(md))
    assert titles == [T.RUNS.title, T.DEFLECTION.title, "Deformed shape at chosen instants", T.STRESS.title,
                      T.SPECTRA.title, T.MODES.title, T.TIMING.title, T.ACCURACY.title, T.CONVERGENCE.title,
                      T.PROVENANCE.title]
    assert [ORDER.index(t) for t in titles] == sorted(ORDER.index(t) for t in titles)
    assert len(pages.SECTIONS) == len(set(pages.SECTIONS))


def test_html_and_markdown_carry_the_same_numbers(report):
    """Each section's tables show the same numbers, in the same order, in the page's HTML and its
    Markdown: both are filled from the page's one table of numbers."""
    html_parts = sections_html((report / "cantilever_step" / "index.html").read_text())
    md_parts = sections_md((report / "cantilever_step" / "index.md").read_text())
    compared = 0
    for title, body in html_parts.items():
        got = table_numbers_html(body)
        assert got == table_numbers_md(md_parts[title]), title
        compared += bool(got)
    assert compared >= 4                        # runs, spectra peaks, timing, accuracy, provenance


def test_one_value_fills_both_formats():
    """A template pair filled once: a value given in both forms goes to each format, any other
    reads the same in both."""
    got = pages.fill(T.TIMING, table=pages.table(["solver", "wall [s]"], [["a", 1.5], ["b", float("nan")]]))
    assert f"<td>{tables.fmt(1.5)}</td>" in got.html and f"| {tables.fmt(1.5)} |" in got.md
    assert table_numbers_html(got.html) == table_numbers_md(got.md)
    assert pages.fill(T.IMAGE, src="x.png") == ("<p><img src='x.png' alt='x.png'></p>", "![x.png](x.png)\n\n")


def test_the_frequency_map_section_names_its_peers_and_carries_its_numbers(tmp_path):
    """A case with a [frequency_map] (cantilever_step, h swept through b, 2 modes): the section's
    figure and CSV beside the page; its table at each value with fe-linear's frame against the
    nearest of flexmbd's frequencies (the in-plane one: the planar frame has no out-of-plane
    bending, which flexmbd's second retained mode is), within 1e-4 (the 100-element frame against
    the reduced beam: measured 5e-5); a peer without an eigen-solve named with its reason; the
    same numbers in HTML and Markdown."""
    from types import SimpleNamespace
    from flexmbd import cases
    case = cases.load("cantilever_step", ['frequency_map={key="bodies.beam.section.h", start=0.008, stop=0.012, '
                                          'values=3, tracks=2, peers=["fe-linear", "mujoco-rod"]}',
                                          "bodies.beam.modes.count=2"])
    (part,) = pages.frequency_map_part(SimpleNamespace(case=case, folder=tmp_path))
    title, body = part[0], part[1:]
    assert title == T.FREQUENCY_MAP.title
    assert (tmp_path / "frequency_map.csv").is_file() and (tmp_path / "frequency_map.png").is_file()
    page_html, page_md = body
    assert "mujoco-rod: it has no eigen-solve of the assembled system" in html.unescape(page_html)
    rows = re.findall(r"<tr><td>(0\.0\d+)</td>((?:<td>[^<]*</td>)+)</tr>", page_html)
    assert len(rows) >= 3
    for _, cells in rows[:3]:
        diff = float(re.findall(r"<td>([^<]*)</td>", cells)[-1])
        assert diff < 1e-4
    assert table_numbers_html(page_html) == table_numbers_md(page_md)
