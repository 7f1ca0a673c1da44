"""Failing fixtures: one small case per check code, with the line the finding must point at.

`BASE` is a minimal valid case; each fixture is a whole file so the expected line can be read
off directly. Shared by the loader and check tests and by the coverage test of every code.
"""

from __future__ import annotations

HEAD = "module: {name: t}\nmonitor: {channels: [lav, tfuse]}\n"

BASE = HEAD + "G1:\n  text: top\n  supportedBy: [Sn1]\nSn1:\n  text: evidence\n"


def case(body: str) -> str:
    """HEAD (lines 1-2) followed by `body` (which starts at line 3)."""
    return HEAD + body


#: (code, YAML text, expected line, expected column or None for "do not care")
LOADER_FIXTURES: list[tuple[str, str, int, int | None]] = [
    ("CW002", "module: {name: t}\ntext: caf\xe9\n", 2, 10),  # replaced by bytes in the test
    ("CW003", case("G1:\n  text: [unclosed\n"), 5, 1),
    ("CW004", "- G1\n- G2\n", 1, 1),
    ("CW005", case("G1:\n  text: a\n  text: b\n"), 5, 3),
    ("CW006", case("G1: &top\n  text: a\nG2:\n  text: b\n  supportedBy: *top\n"), 7, 16),
    (
        "CW007",
        case(
            "G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n"
            "  spi: {signal: els, threshold: '>= 0.6', for: 1_0}\n"
        ),
        6,
        48,
    ),
    ("CW010", "monitor: {channels: [lav, tfuse]}\nG1: {text: a, undeveloped: true}\n", 1, 1),
    ("CW011", "module: {name: t}\nG1: {text: a, undeveloped: true}\n", 1, 1),
    ("CW012", case("G1:\n  text: top\n  undeveloped: maybe\n"), 5, 16),
    ("CW013", case("G1:\n  text: top\n  suportedBy: [Sn1]\nSn1: {text: e}\n"), 5, 3),
    ("CW014", case("G1:\n  undeveloped: true\n"), 3, 1),
    (
        "CW016",
        case(
            "G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n"
            "  spi: {signal: els, threshold: '0.6'}\n"
        ),
        6,
        33,
    ),
    (
        "CW015",
        case(
            "G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n"
            "  spi: {signal: els, threshold: '>= 0.6', warn: -0.1}\n"
        ),
        6,
        49,
    ),
    (
        "CW017",
        case(
            "G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n"
            "  spi: {signal: els, threshold: '>= 0.6', for: 3 parsecs}\n"
        ),
        6,
        48,
    ),
    (
        "CW018",
        case("G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n  spi: {signal: els}\n"),
        6,
        8,
    ),
    (
        "CW019",
        "module: {name: t}\nmonitor:\n  channels: [lav]\nG1: {text: a, undeveloped: true}\n",
        3,
        13,
    ),
    ("CW020", case("G1: {text: t, undeveloped: true}\nGoal1: {text: x}\n"), 4, 1),
    (
        "CW028",
        "module:\n  name: t\n  uses: [no-such-module.gsn.yaml]\nmonitor: {channels: [a, b]}\n"
        "G1: {text: t, undeveloped: true}\n",
        3,
        10,
    ),
    (
        "CW008",
        case(
            "G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n  contract: {use: rss_longitudnal}\n"
        ),
        6,
        19,
    ),
    (
        "CW009",
        case(
            "G1: {text: t, supportedBy: Sn1, inContextOf: C1}\nSn1: {text: e}\nC1:\n"
            "  text: c\n  odd: {attributes: {weather: [clear]}}\n"
        ),
        7,
        8,
    ),
    (
        "CW021",
        case("G1:\n  text: t\n  undeveloped: true\n  spi: {signal: els, threshold: '>1'}\n"),
        6,
        3,
    ),
    (
        "CW022",
        case("G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n  hazard: {when: x > 1}\n"),
        6,
        3,
    ),
    ("CW023", case("G1: {text: t, supportedBy: Sn1}\nSn1:\n  text: e\n  challenges: G1\n"), 6, 3),
    ("CW063", "G1:\n  text: a\n  undevelopped: true\n", 3, 3),
    (
        "CW065",
        "module:\n  name: m\n  extends: [{module: other, develops: {G1: [G2]}}]\n"
        "G2: {text: t, undeveloped: true}\n",
        3,
        3,
    ),
    (
        "CW025",
        "module: {name: t}\nmonitor:\n  channels: [lav, tfuse]\n  signals: [speed, els]\n"
        "G1: {text: a, undeveloped: true}\n",
        4,
        20,
    ),
]

#: Structural check fixtures (the file loads; the graph is wrong).
CHECK_FIXTURES: list[tuple[str, str, int, int | None]] = [
    ("CW024", BASE + "CSn1:\n  text: hazard\n  hazard: {when: 'els < 0.1'}\n", 8, 1),
    (
        "CW026",
        BASE + "CG1:\n  text: c\n  challenges: G1\n  supportedBy: [CSn1]\n"
        "CSn1:\n  text: d\n  challenges: [CG1]\n",
        14,
        16,
    ),
    (
        "CW027",
        case(
            "G1:\n  text: top\n  supportedBy: [Sn1]\n  inContextOf: [C1]\nSn1: {text: e}\n"
            "C1: {text: c}\nCSn1:\n  text: d\n  challenges: [C1]\n"
            "  hazard: {when: 'els < 0.5'}\n"
        ),
        11,
        16,
    ),
    ("CW030", case("G1:\n  text: top\n  supportedBy: [Sn1, Sn2]\nSn1: {text: e}\n"), 5, 22),
    (
        "CW031",
        case("G1:\n  text: top\n  supportedBy: [Sn1]\n  inContextOf: [G1]\nSn1: {text: e}\n"),
        6,
        17,
    ),
    (
        "CW032",
        case("G1:\n  text: top\n  supportedBy: [Sn1, C1]\nSn1: {text: e}\nC1: {text: c}\n"),
        5,
        22,
    ),
    (
        "CW033",
        case("G1:\n  text: top\n  supportedBy: [Sn1]\n  inContextOf: Sn1\nSn1: {text: e}\n"),
        6,
        16,
    ),
    (
        "CW034",
        case(
            "G1: {text: top, supportedBy: [G2]}\nG2: {text: a, supportedBy: [G3]}\n"
            "G3: {text: b, supportedBy: [G2, Sn1]}\nSn1: {text: e}\n"
        ),
        4,
        29,
    ),
    ("CW035", BASE + "G2:\n  text: another top\n  undeveloped: true\n", 8, 1),
    ("CW036", case("S1:\n  text: strategy on top\n  supportedBy: [Sn1]\nSn1: {text: e}\n"), 3, 1),
    ("CW037", BASE + "C1:\n  text: context nobody uses\n", 8, 1),
    (
        "CW038",
        case("G1:\n  text: top\n  supportedBy: [Sn1]\n  undeveloped: true\nSn1: {text: e}\n"),
        6,
        3,
    ),
    ("CW039", case("G1:\n  text: top\n"), 3, 1),
    # gsn2x's rules (a pure argument, no monitor): a second root only warns
    ("CW061", "G1: {text: a, undeveloped: true}\nG2: {text: b, undeveloped: true}\n", 2, 1),
    (
        "CW062",
        BASE + "G2: {text: g, undeveloped: true}\nCSn1:\n  text: d\n  challenges: G1 -> G2\n",
        11,
        15,
    ),
    ("CW064", BASE + "CSn1:\n  text: d\n  challenges: G1 -> Sn1\n", 10, 15),
    ("CW066", case("G1:\n  text: top\n  undeveloped: true\n  defeated: true\n"), 6, 3),
    ("CW067", case("G1:\n  text: top\n  undeveloped: true\n  acp: {ACP1: Sn1}\n"), 6, 3),
    ("CW068", case("G1:\n  text: top\n  supportedBy: [Sn1, Sn1]\nSn1: {text: e}\n"), 5, 3),
]
