"""The executed report notebook -> one HTML file that opens offline (rule report_html; ARCHITECTURE 5: nbconvert's
default page pulls require.js from a CDN). Apart from :mod:`mrhyst.report.collect` so that the rule, the last link of
the build, does not import pandas and the study's modules for it (~0.25 s)."""

from __future__ import annotations

import re
from pathlib import Path

from mrhyst.data.io import atomic_path

_EXT_REF = re.compile(r"""(?:\bsrc|\bhref|@import|\burl\(|import\()\s*=?\s*\(?\s*["']?\s*((?:https?:)?//[^"'\s)>]+)""",
                      re.IGNORECASE)


def external_refs(html: str) -> list[str]:
    """Every URL the page would fetch or link to outside itself: src=/href= attributes, CSS @import and
    url(), and JS import() pointing at http(s):// or protocol-relative //host."""
    return sorted(set(_EXT_REF.findall(html)))


def export_html(nb_path, out_html, template_file) -> str:
    """Executed notebook -> one self-contained HTML (inputs hidden, prompts hidden, no network).

    template_file: a Jinja template extending nbconvert's ``lab`` template with the script blocks
    (require.js, MathJax, mermaid, widgets) emptied. Raises ValueError if the result still refers to
    anything outside itself; the file is written atomically."""
    import nbformat
    from nbconvert import HTMLExporter

    nb = nbformat.read(str(nb_path), as_version=4)
    exporter = HTMLExporter(template_name="lab", template_file=str(Path(template_file).resolve()),
                            exclude_input=True, exclude_input_prompt=True, exclude_output_prompt=True,
                            embed_images=True)
    exporter.mathjax_url = ""
    exporter.require_js_url = ""
    body, _ = exporter.from_notebook_node(nb, resources={"metadata": {"name": Path(nb_path).stem}})
    refs = external_refs(body)
    if refs:
        raise ValueError(f"{out_html}: the HTML refers to {len(refs)} outside resource(s), e.g. {refs[0]}")
    if not body.endswith("\n"):
        body += "\n"
    with atomic_path(out_html) as tmp:
        tmp.write_text(body, encoding="utf-8")
    return body
