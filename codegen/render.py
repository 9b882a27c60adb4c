"""The Jinja environment shared by every generator: templates are package data. Jinja loads on
the first render, so that commands which draw or write nothing do not pay for it at start-up."""
from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import jinja2


@lru_cache(maxsize=1)
def environment() -> "jinja2.Environment":
    import jinja2
    return jinja2.Environment(loader=jinja2.PackageLoader("codegen", "templates"), autoescape=False,
                              keep_trailing_newline=True, trim_blocks=True, lstrip_blocks=True,
                              undefined=jinja2.StrictUndefined)


def render(template: str, **context: Any) -> str:
    return environment().get_template(template).render(**context)
