"""The documentation: README as a landing page, the command-line reference generated from the
parser (every option of every subcommand appears, with its help text), and the MkDocs site
building with ``mkdocs build --strict`` (every page in the nav exists, every link and anchor
resolves, the API reference renders from the docstrings)."""
from __future__ import annotations

import argparse
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

from cyclo_fmu.cli import build_parser
from cyclo_fmu.cli_reference import MARKER, option_strings, render_cli_reference

ROOT = Path(__file__).resolve().parent.parent
#: The landing page's limit [lines] (issue 21: "at most about 250 lines").
README_MAX_LINES = 250
#: README's test command, which .ci/run runs.
TEST_COMMAND = 'pip install -e ".[test]" && python -m pytest -q'


def _sections(markdown: str) -> dict[str, str]:
    """The rendered reference cut into its ``## `name` `` sections."""
    parts = re.split(r"^## `([^`]+)` \{#[^}]+\}$", markdown, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2]))


def test_every_cli_option_and_its_help_is_in_the_generated_reference():
    md = render_cli_reference()
    sections = _sections(md)
    options = option_strings()
    assert set(sections) == set(options), "a subcommand is missing from the reference"
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, strings in options.items():
        for s in strings:
            assert f"`{s}`" in sections[name], f"{name} {s} is not in the CLI reference"
        for action in sub.choices[name]._actions:
            if action.help and action.help != argparse.SUPPRESS and \
                    not isinstance(action, argparse._HelpAction):
                assert " ".join(action.help.split()) in sections[name], \
                    f"the help of {name} {action.option_strings or action.dest} differs"


def test_the_reference_follows_a_new_option():
    """The page is rendered from whatever the parser holds: an option added to the parser
    appears without editing any page."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    sub.choices["stiffness"].add_argument("--made-up-option", choices=["a", "b"],
                                          help="an option the docs never heard of")
    md = _sections(render_cli_reference(parser))["stiffness"]
    assert "`--made-up-option`" in md and "an option the docs never heard of" in md
    assert "one of `a`, `b`" in md


def test_the_cli_page_is_generated():
    page = (ROOT / "docs" / "reference" / "cli.md").read_text(encoding="utf-8")
    assert MARKER in page


def test_readme_is_a_landing_page():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= README_MAX_LINES
    setup = text.split("## Set up", 1)[1].split("\n## ", 1)[0]
    commands = [line.strip() for line in setup.splitlines()
                if line.startswith("    ") and line.strip()]
    assert len(commands) == 2, commands                       # exactly two set-up commands
    assert all(c.startswith("python3 -m venv .venv && . .venv/bin/activate") for c in commands)
    assert commands[1].endswith(TEST_COMMAND)
    assert TEST_COMMAND in (ROOT / ".ci" / "run").read_text()
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert (ROOT / image).is_file(), f"README shows {image}, which is not committed"


def test_readme_links_exist():
    """Every relative link of the landing page points at a file of the repository (the pages
    written in other branches included, once merged)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    for link in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if "://" not in link:
            assert (ROOT / link).is_file(), f"README links to {link}, which does not exist"


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None
                    or importlib.util.find_spec("mkdocstrings") is None,
                    reason="mkdocs and mkdocstrings are not installed "
                           "(pip install -e '.[docs]')")
def test_mkdocs_build_strict(tmp_path):
    site = tmp_path / "site"
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict",
                          "-d", str(site)], cwd=ROOT, capture_output=True, text=True,
                         timeout=600, env={**__import__("os").environ,
                                           "NO_MKDOCS_2_WARNING": "1"})
    problems = [line for line in (run.stdout + run.stderr).splitlines()
                if "WARNING" in line or "ERROR" in line or "Error" in line]
    assert run.returncode == 0, "\n".join(problems) or run.stderr[-2000:]
    cli_html = (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    for name, strings in option_strings().items():
        for s in strings:
            assert s in cli_html, f"{name} {s} is not on the built CLI page"
    api = (site / "reference" / "api" / "model_core" / "index.html").read_text(encoding="utf-8")
    assert "operating_point" in api and "kreines_efficiency" in api


FMUS = ("CycloidDrive", "CycloidDriveNative", "InductionMotor", "FeltBrake", "Transducer")


@pytest.mark.parametrize("name", FMUS)
def test_every_fmu_variable_is_in_the_generated_table(name):
    from cyclo_fmu.fmu_reference import model_description, render_fmu_variables, variables
    table = render_fmu_variables(name)
    for v in variables(model_description(name)):
        if not v["name"].startswith("_"):
            assert f"| `{v['name']}` | {v['causality']}, {v['variability']} |" in table


def _built_variables(fmu_path):
    import zipfile
    import xml.etree.ElementTree as ET
    from cyclo_fmu.fmu_reference import variables
    with zipfile.ZipFile(fmu_path) as z:
        md = ET.fromstring(z.read("modelDescription.xml"))
    return [(v["name"], v["causality"], v["variability"], v["type"], v["unit"])
            for v in variables(md)]


def test_generated_fmu_tables_match_the_built_fmus(fmu_dir, tmp_path):
    """The docs' variable lists are what a host reads from the built FMUs (names, causality,
    variability, type, unit, in order)."""
    from cyclo_fmu.fmu_reference import model_description, variables
    from cyclo_fmu.native.build import build_native_fmu
    built = {name: fmu_dir / f"{name}.fmu" for name in FMUS if name != "CycloidDriveNative"}
    built["CycloidDriveNative"] = build_native_fmu(dest=tmp_path)
    for name, path in built.items():
        documented = [(v["name"], v["causality"], v["variability"], v["type"], v["unit"])
                      for v in variables(model_description(name))]
        assert documented == _built_variables(path), name


def _contract_section(anchor: str) -> str:
    page = (ROOT / "docs" / "reference" / "contracts.md").read_text(encoding="utf-8")
    return page.split(f"{{#{anchor}}}", 1)[1].split("\n## ", 1)[0]


@pytest.mark.parametrize("argv, anchor", [
    (["efficiency", "--mode", "S1", "--speed", "2800", "--torque", "0.85", "--json"],
     "efficiency"),
    (["stiffness", "--json"], "stiffness")])
def test_json_contract_page_names_every_key(argv, anchor, capsys):
    """Every key a --json command prints (nested objects' keys too) is named on the contracts
    page, in that command's section."""
    import json
    from cyclo_fmu.cli import main
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    section = _contract_section(anchor)

    def keys(obj):
        for k, v in obj.items():
            yield k
            if isinstance(v, dict) and not set(v) <= {"PL1", "PL2", "PL3", "PL5", "PL6"}:
                yield from keys(v)
    for k in keys(out):
        assert re.search(rf"\b{re.escape(k)}\b", section), f"{anchor} --json key {k} undocumented"
