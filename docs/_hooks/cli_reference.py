"""MkDocs hook: renders the command-line reference from argparse (``cyclo_fmu.cli_reference``)
into the page that holds the marker, and the default design file into the page that holds
``<!-- default-design -->``. Generated at build time, so the docs cannot disagree with --help."""
from cyclo_fmu.cli_reference import MARKER, render_cli_reference

DESIGN_MARKER = "<!-- default-design -->"


def on_page_markdown(markdown, page, config, files, **kwargs):
    if MARKER in markdown:
        markdown = markdown.replace(MARKER, render_cli_reference())
    if DESIGN_MARKER in markdown:
        from model_core import DriveDesign, design_to_toml
        markdown = markdown.replace(
            DESIGN_MARKER, "```toml\n" + design_to_toml(DriveDesign()).rstrip() + "\n```")
    return markdown
