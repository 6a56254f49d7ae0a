"""The generated reference pages are current and complete.

``docs/scenario-files.md`` and ``docs/cli.md`` are written by ``python -m scenarios.docgen``.
These checks regenerate them in memory and compare, and walk the sources themselves (the
loader's key lists and spec classes, the argument parser) independently of the generator: every
key the loader accepts has a documented row, every subcommand and option string is on the CLI
page, and the example files on the scenario page load. A synthetic spec with an undocumented
key shows the generator refusing it.
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import tomllib
from dataclasses import dataclass, fields
from functools import cache
from pathlib import Path

import pytest

from scenarios import docgen
from scenarios.cli.parser import build_parser
from scenarios.loader import (
    ROBOT_KEYS,
    SCENARIO_KEYS,
    SECTIONS,
    TOP_SECTIONS,
    load_scenario,
    parse_scenario,
)
from sim.scenario import SpatialSpec
from sim.scenario.schema import setting, tables_of

ROOT = Path(__file__).resolve().parents[2]
RUN = "run: python -m scenarios.docgen"
PAGES = (docgen.SCENARIO_PAGE, docgen.CLI_PAGE)


@cache
def generated() -> dict[str, str]:
    return docgen.pages()


def page(rel: str) -> str:
    path = ROOT / rel
    assert path.is_file(), f"{rel} is missing; {RUN}"
    return path.read_text(encoding="utf-8")


def sections(text: str) -> dict[str, str]:
    """{heading text of a ``## `` section: its body}; the part before the first under ''."""
    parts = re.split(r"^## (.*)$", text, flags=re.M)
    return {"": parts[0], **dict(zip(parts[1::2], parts[2::2], strict=True))}


@pytest.mark.parametrize("rel", PAGES)
def test_generated_page_is_current(rel):
    old, new = page(rel).splitlines(), generated()[rel].splitlines()
    if old != new:
        n = next(
            (i for i, (a, b) in enumerate(zip(old, new, strict=False)) if a != b),
            min(len(old), len(new)),
        )
        pytest.fail(f"{rel} is out of date from line {n + 1} on; {RUN}", pytrace=False)
    assert page(rel) == generated()[rel], f"{rel}: line endings differ; {RUN}"


def test_check_and_write(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(docgen, "ROOT", tmp_path)
    assert docgen.main(["--check"]) == 1
    assert capsys.readouterr().out.splitlines() == [f"{rel}: missing ({RUN})" for rel in PAGES]
    assert docgen.main([]) == 0
    assert docgen.main(["--check"]) == 0
    assert (tmp_path / docgen.CLI_PAGE).read_text(encoding="utf-8") == generated()[docgen.CLI_PAGE]


# --- docs/scenario-files.md ----------------------------------------------------------------


def accepted_keys() -> dict[str, set[str]]:
    """{table as the page heads it: the keys the loader accepts there}, from the sources."""
    assert set(TOP_SECTIONS) == {"scenario", "robots", *SECTIONS, "spatial"}
    out = {"[scenario]": set(SCENARIO_KEYS), "[[robots]]": set(ROBOT_KEYS)}
    out |= {f"[{name}]": {f.name for f in fields(cls)} for name, cls in SECTIONS.items()}
    out["[spatial]"] = {f.name for f in fields(SpatialSpec)}
    out["[spatial.sites]"] = {docgen.SITE_KEY}  # one key per task type
    for f in tables_of(SpatialSpec):
        out[f"[spatial.{f.name}]"] = {g.name for g in fields(f.default_factory)}
    return out


def documented_keys(text: str) -> dict[str, dict[str, str]]:
    """{table: {key: its 'what it changes' cell}} of the page's key tables."""
    out = {}
    for heading, body in sections(text).items():
        m = re.fullmatch(r"`(\[.*\])`", heading)
        if m:
            rows = re.findall(r"^\| `([^`]+)` \|.*\| ([^|]*) \|$", body, flags=re.M)
            out[m.group(1)] = {key: what.strip() for key, what in rows}
    return out


def test_every_key_the_loader_accepts_is_documented():
    documented = documented_keys(page(docgen.SCENARIO_PAGE))
    missing = [
        f"{table} {key}"
        for table, keys in accepted_keys().items()
        for key in sorted(keys)
        if not documented.get(table, {}).get(key)
    ]
    assert not missing, f"keys without a documented row ({RUN}): " + ", ".join(missing)
    extra = sorted(set(documented) - set(accepted_keys()))
    assert not extra, f"tables the loader does not accept: {extra}"


@dataclass(frozen=True)
class _Spec:
    documented: int = setting(1, "a key with its doc line", lo=0, hi=9)
    undocumented: float = 2.0  # a new key with no declaration and no hand-written line


@dataclass(frozen=True)
class _Blank:
    blank: int = setting(1, " ", lo=0, hi=9)


def test_a_key_without_a_doc_line_is_refused():
    with pytest.raises(docgen.DocGenError, match=r"^fake\.undocumented: "):
        docgen.key_rows("fake", _Spec)
    with pytest.raises(docgen.DocGenError, match=r"^fake\.blank: declared without a doc line"):
        docgen.key_rows("fake", _Blank)
    with pytest.raises(docgen.DocGenError, match=r"^fake\.name: "):  # accepted, not a field
        docgen.key_rows("fake", _Spec, keys=("documented", "name"))
    hand = {"fake.undocumented": ("number", "2.0", "what it changes")}
    rows = docgen.key_rows("fake", _Spec, hand=hand)
    assert [(r[0], r[-1]) for r in rows] == [
        ("documented", "a key with its doc line"),
        ("undocumented", "what it changes"),
    ]


def test_the_page_refuses_a_new_undocumented_table_key(monkeypatch):
    monkeypatch.setattr(docgen, "SECTIONS", {**SECTIONS, "fake": _Spec})
    monkeypatch.setattr(docgen, "TOP_SECTIONS", (*TOP_SECTIONS, "fake"))
    with pytest.raises(docgen.DocGenError, match=r"^fake\.undocumented: "):
        docgen.scenario_page()
    monkeypatch.setattr(docgen, "TOP_SECTIONS", (*TOP_SECTIONS, "unheard_of"))
    with pytest.raises(docgen.DocGenError, match=r"^unheard_of: "):
        docgen.scenario_page()


def test_the_example_files_load():
    blocks = re.findall(r"^```toml\n(.*?)^```$", page(docgen.SCENARIO_PAGE), flags=re.M | re.S)
    assert len(blocks) == len(docgen.EXAMPLES) == 2
    spatial = []
    for name, block in zip(docgen.EXAMPLES, blocks, strict=True):
        scenario = parse_scenario(tomllib.loads(block))
        bundled = load_scenario(name)  # the example is the bundled file, defaults left out
        same = dataclasses.replace(bundled, source=scenario.source, source_sha256="")
        assert scenario == same, f"the example of {name} differs from scenarios/data/{name}.toml"
        spatial.append(scenario.spatial is not None)
    assert spatial == [False, True]


# --- docs/cli.md ---------------------------------------------------------------------------


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """{name: parser} of every subcommand (argparse has no public API to list them)."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return {name: p for action in subs for name, p in action.choices.items()}


def missing_options(parser: argparse.ArgumentParser, body: str) -> list[str]:
    """Option strings (and positional names) of ``parser`` that ``body`` does not show."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            continue
        out += [s for s in action.option_strings or [action.dest] if f"`{s}`" not in body]
    return out


def test_every_subcommand_and_option_is_on_the_cli_page():
    parser = build_parser()
    found = sections(page(docgen.CLI_PAGE))
    missing = [f"mrta {s}" for s in missing_options(parser, found[""])]
    for name, sub in subcommands(parser).items():
        body = found.get(f"`mrta {name}`")
        if body is None:
            missing.append(f"mrta {name} (no section)")
            continue
        missing += [f"mrta {name} {s}" for s in missing_options(sub, body)]
        assert f"[`mrta {name}`](#mrta-{name})" in found[""], f"mrta {name} not in the index"
    assert len(subcommands(parser)) >= 10
    assert not missing, f"not on {docgen.CLI_PAGE} ({RUN}): " + ", ".join(missing)
