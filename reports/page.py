"""The standalone HTML pages beside the run report (fleet, diff, tuning, odd, compare): one
jinja2 setup for all of them.

Each page is one template from `reports/templates`, autoescaped, strict about undefined names,
with the report stylesheet inlined as `css` so the file needs nothing beside it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import jinja2

TEMPLATES = Path(__file__).parent / "templates"


def render_page(template: str, filters: dict[str, Callable[..., Any]] | None = None,
                **context: Any) -> str:  # fmt: skip
    """`template` rendered with `context`, the page's own `filters` and `css`."""
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), autoescape=True,
                             undefined=jinja2.StrictUndefined)  # fmt: skip
    env.filters.update(filters or {})
    return env.get_template(template).render(css=(TEMPLATES / "report.css").read_text(),
                                             **context)  # fmt: skip
