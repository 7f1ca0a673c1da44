"""The standalone HTML pages beside the run report (fleet, diff, tuning, odd, compare): one
jinja2 setup for all of them.

Each page is one template from `reports/templates`, autoescaped, strict about undefined names,
with the report stylesheet inlined as `css` so the file needs nothing beside it. The stylesheet
is passed as `Markup`: it is casewatch's own file, and autoescaping it would turn its quotes into
`&#34;` and drop every declaration that has one (the page would fall back to a serif font).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import jinja2
from markupsafe import Markup

TEMPLATES = Path(__file__).parent / "templates"


def render_page(
    template: str, filters: dict[str, Callable[..., Any]] | None = None, **context: Any
) -> str:
    """`template` rendered with `context`, the page's own `filters` and `css`."""
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(TEMPLATES), autoescape=True, undefined=jinja2.StrictUndefined
    )
    env.filters.update(filters or {})
    css = Markup((TEMPLATES / "report.css").read_text(encoding="utf-8"))
    return env.get_template(template).render(css=css, **context)
