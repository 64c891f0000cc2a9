"""MkDocs hook: the equations of the site as MathML, made at build time.

``pymdownx.arithmatex`` (generic mode) wraps TeX in ``<span class="arithmatex">\\(...\\)</span>``
and ``<div class="arithmatex">\\[...\\]</div>``; this hook replaces each by the MathML that
``latex2mathml`` makes of it, which browsers render natively: no MathJax, no script, no network.
An equation latex2mathml cannot convert fails the build (``mkdocs build --strict``), naming the
page and the TeX.
"""

from __future__ import annotations

import html
import logging
import re

log = logging.getLogger("mkdocs.hooks.mathml")

_MATH = re.compile(r'<(span|div) class="arithmatex">\s*\\([(\[])(.*?)\\[)\]]\s*</\1>', re.S)


def on_page_content(content: str, page, config, files) -> str:
    from latex2mathml.converter import convert

    def mathml(match: re.Match) -> str:
        tex = html.unescape(match[3]).strip()
        display = "block" if match[2] == "[" else "inline"
        try:
            return convert(tex, display=display)
        except Exception as exc:  # noqa: BLE001 - any parser error: name the equation
            log.warning("%s: equation %r is not converted to MathML (%s: %s)",
                        page.file.src_path, tex, type(exc).__name__, exc)
            return match[0]

    return _MATH.sub(mathml, content)
