"""The HTML report: escaping, self-containment and content."""

from __future__ import annotations

import re
from html.parser import HTMLParser

from casewatch.evaluator.result import NodeStatus, RunResult, StatusInterval
from casewatch.evaluator.status import summarize
from casewatch.reports.html import render_html


class _Collector(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[str] = []
        self.ids: set[str] = set()
        self.attrs: list[tuple[str, str | None]] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)
        self.attrs += attrs
        for key, value in attrs:
            if key == "id" and value:
                self.ids.add(value)

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def _parse(html: str) -> _Collector:
    collector = _Collector()
    collector.feed(html)
    return collector


def test_hostile_strings_are_escaped_and_no_script_element(hostile_result: RunResult) -> None:
    html = render_html(hostile_result)
    parsed = _parse(html)
    assert "script" not in parsed.tags
    assert "<script" not in html.lower()
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    # the payload survives as visible text in node texts, stream meta keys/values and defects
    text = "".join(parsed.text)
    assert text.count("<script>alert(1)</script>") >= 27  # every node text at least once
    assert 'car \\"big\\" & <b>bold</b>' in text  # object classes (stream meta, as JSON)
    assert "<b>bold</b>" not in html  # never as markup
    assert "b" in parsed.tags  # (real <b> tags of the template exist, so the check above matters)
    assert "\x01" not in html and "\x1b" not in html  # control characters are dropped


def test_self_contained_no_urls_no_javascript(reference_result: RunResult) -> None:
    html = render_html(reference_result)
    assert not re.search(r"(?i)\b(?:https?|ftp)://(?!www\.w3\.org/2000/svg)", html)
    assert not re.search(r"(?i)<(?:script|link|iframe|img|object|embed)\b", html)
    assert not re.search(r"(?i)\son[a-z]+\s*=", html)  # no event handler attributes
    assert "javascript:" not in html.lower()
    parsed = _parse(html)
    # only same-document links
    hrefs = [v for k, v in parsed.attrs if k == "href"]
    assert hrefs and all(v.startswith("#") for v in hrefs)
    for key, value in parsed.attrs:
        if key == "marker-end":
            assert value.startswith("url(#")


def test_every_episode_and_node_has_a_section(reference_result: RunResult) -> None:
    parsed = _parse(render_html(reference_result))
    for number in range(1, len(reference_result.episodes) + 1):
        assert f"episode-{number}" in parsed.ids
    for node in reference_result.case.nodes:
        assert f"node-{node.id}" in parsed.ids
        assert f"diagram-{node.id}" in parsed.ids


def test_diagram_nodes_link_to_sections_and_carry_their_status(reference_result: RunResult) -> None:
    html = render_html(reference_result)
    period = reference_result.case.period
    worst = {s.node_id: summarize(s, period).status for s in reference_result.status}
    for node in reference_result.case.nodes:
        pattern = (
            rf'<a href="#node-{node.id}"><g class="gsn-node st-{worst[node.id]}'
            rf'[^"]*" id="diagram-{node.id}"'
        )
        assert re.search(pattern, html), node.id
    assert html.count('class="gsn-node') == len(reference_result.case.nodes)
    assert html.count("· counter") == 3  # the three CSn hazards are marked as counters


def test_spi_table_numbers(reference_result: RunResult) -> None:
    html = render_html(reference_result)
    sn1 = next(f for f in reference_result.formulas if f.id == "Sn1")
    share = 100 * sn1.ticks_violated / sn1.ticks_evaluated
    row = re.search(r'<tr class="bad"><td><a href="#node-Sn1">.*?</tr>', html, re.S)
    assert row is not None
    cells = row.group(0)
    assert f"{sn1.ticks_violated:,} / {sn1.ticks_evaluated:,}" in cells
    assert f"{share:.1f} %" in cells
    assert f">{sn1.episodes}<" in cells
    assert f"{sn1.worst_robustness:+.3f}" in cells


def test_one_plot_per_formula_with_threshold_and_episodes(reference_result: RunResult) -> None:
    html = render_html(reference_result)
    for formula in reference_result.formulas:
        assert f'id="plot-{formula.id}"' in html
    section = html.split('id="plot-Sn1"')[1].split("</svg>")[0]
    assert 'class="reference"' in section
    assert section.count('class="ep-span"') >= 1
    assert 'class="band"' in section


def test_headline_shows_verdict_digests_and_counts(reference_result: RunResult) -> None:
    html = render_html(reference_result)
    assert f'class="verdict bg-{reference_result.verdict}"' in html
    assert reference_result.case.digest in html
    assert reference_result.stream.digest in html
    assert f"{reference_result.stream.frames_read:,}" in html
    assert "3 min 0 s" in html  # 1800 frames at 0.1 s


def test_incomplete_run_is_flagged(reference_result: RunResult) -> None:
    html = render_html(reference_result.model_copy(update={"complete": False}))
    assert "Incomplete run" in html


def test_long_lists_are_capped_with_a_count(reference_result: RunResult) -> None:
    gap = reference_result.data_gaps[0]
    many = reference_result.model_copy(update={"data_gaps": [gap] * 250})
    html = render_html(many)
    assert "and 50 more data gaps" in html  # 250 gaps, 200 shown


def test_a_warm_up_tick_leaves_the_node_satisfied_and_the_share_says_so(
    reference_result: RunResult,
) -> None:
    """Sn8 satisfied on all ticks but the first (warm-up): coloured satisfied, with the no-data
    share marked as warm-up; a violation of a single tick still colours its node."""
    first = reference_result.status[0].timeline[0]
    total = sum(reference_result.status[0].ticks.values())
    t_end = reference_result.status[0].timeline[-1].end
    warm = NodeStatus(
        node_id="Sn8",
        worst="no-data",
        ticks={"no-data": 1, "satisfied": total - 1},
        timeline=[
            StatusInterval(status="no-data", start=first.start, end=first.start, ticks=1),
            StatusInterval(status="satisfied", start=first.start + 0.1, end=t_end, ticks=total - 1),
        ],
    )
    status = [warm if s.node_id == "Sn8" else s for s in reference_result.status]
    html = render_html(reference_result.model_copy(update={"status": status}))
    assert re.search(r'<g class="gsn-node st-satisfied[^"]*" id="diagram-Sn8"', html)
    section = html.split('id="node-Sn8"', 1)[1].split('id="node-', 1)[0]
    assert "no data &lt;0.1 % (all warm-up) · satisfied 99.9 %" in section
    assert "pill satisfied" in section.split("</h3>")[0]


def test_the_verdict_card_follows_the_root_s_colour_and_names_the_worst_tick(
    reference_result: RunResult,
) -> None:
    """A run whose root goal lacked data only on its first tick: the card reads satisfied, like
    the root in the diagram, and says the verdict in result.json is no data (all warm-up)."""
    from casewatch.reports.markdown import render_markdown

    root = next(s for s in reference_result.status if s.node_id == "G1")
    total, first = sum(root.ticks.values()), root.timeline[0]
    warm = NodeStatus(
        node_id="G1",
        worst="no-data",
        ticks={"no-data": 1, "satisfied": total - 1},
        timeline=[
            StatusInterval(status="no-data", start=first.start, end=first.start, ticks=1),
            StatusInterval(
                status="satisfied",
                start=first.start + 0.1,
                end=root.timeline[-1].end,
                ticks=total - 1,
            ),
        ],
    )
    status = [warm if s.node_id == "G1" else s for s in reference_result.status]
    run = reference_result.model_copy(update={"status": status, "verdict": "no-data"})
    html = render_html(run)
    card = html.split('<div class="verdict', 1)[1].split('<div class="facts">', 1)[0]
    assert card.startswith(' bg-satisfied">') and '<div class="word">satisfied</div>' in card
    assert (
        "worst tick: no data (all warm-up), &lt;0.1 % of the run (the verdict in result.json)"
        in card
    )
    assert re.search(r'<g class="gsn-node st-satisfied[^"]*" id="diagram-G1"', html)
    md = render_markdown(run)
    assert "**Top claim G1: SATISFIED**" in md and "Worst tick: no data (all warm-up)" in md
    # unchanged, the card takes G1's colour, and names the worst tick only when it differs
    plain = render_html(reference_result)
    colour = summarize(root, reference_result.case.period).status
    assert f'<div class="verdict bg-{colour}">' in plain
    assert ("worst tick:" in plain) == (colour != reference_result.verdict)
