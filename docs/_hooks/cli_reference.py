"""MkDocs hook: renders the command-line reference from argparse (``cyclo_fmu.cli_reference``)
into the page that holds the marker, the FMUs' variables from their modelDescription.xml
(``cyclo_fmu.fmu_reference``, marker ``<!-- fmu-variables NAME -->``), and the default design
file into the page that holds ``<!-- default-design -->``. Generated at build time, so the docs cannot disagree with --help."""
from cyclo_fmu.cli_reference import MARKER, render_cli_reference

DESIGN_MARKER = "<!-- default-design -->"


def on_page_markdown(markdown, page, config, files, **kwargs):
    if MARKER in markdown:
        markdown = markdown.replace(MARKER, render_cli_reference())
    from cyclo_fmu.fmu_reference import MARKER as FMU_MARKER, render_fmu_variables
    markdown = FMU_MARKER.sub(lambda m: render_fmu_variables(m.group(1)), markdown)
    if DESIGN_MARKER in markdown:
        from model_core import DriveDesign, design_to_toml
        markdown = markdown.replace(
            DESIGN_MARKER, "```toml\n" + design_to_toml(DriveDesign()).rstrip() + "\n```")
    return markdown


# -- numpydoc docstrings are written for Sphinx (pvlib style: ``.. math::`` blocks and :func:
# roles); mkdocstrings renders them as Markdown, so the API pages would show the directives
# as text. These substitutions turn them into MathJax and plain code.
import html as _html
import re as _re

_MATH_BLOCK = _re.compile(r'<p>\.\. math::</p>\s*<div class="highlight"><pre><span></span>'
                          r'<code>(.*?)</code></pre></div>', _re.S)
_MATH_LINE = _re.compile(r"<p>\.\. math::\s*(.+?)</p>", _re.S)
_MATH_ROLE = _re.compile(r":math:<code>(.*?)</code>", _re.S)
_ROLE = _re.compile(r":(?:py:)?(?:func|mod|class|meth|attr|data|obj|exc|const):(<code>)")


def _tex(escaped: str) -> str:
    """Docstring TeX as HTML text for MathJax (double backslashes of non-raw strings undone)."""
    return _html.escape(_html.unescape(escaped).replace("\\\\", "\\").strip(), quote=False)


def on_page_content(html, page, config, files, **kwargs):
    if "math::" not in html and ":math:" not in html and _ROLE.search(html) is None:
        return html
    html = _MATH_BLOCK.sub(lambda m: f'<div class="arithmatex">\\[{_tex(m.group(1))}\\]</div>',
                           html)
    html = _MATH_LINE.sub(lambda m: f'<div class="arithmatex">\\[{_tex(m.group(1))}\\]</div>',
                          html)
    html = _MATH_ROLE.sub(lambda m: f'<span class="arithmatex">\\({_tex(m.group(1))}\\)</span>',
                          html)
    return _ROLE.sub(r"\1", html)
