"""The documentation stays true to the repository: README length, links, commands, pictures.

Fast checks over README.md, CHANGELOG.md and docs/**/*.md: every relative link and image
resolves (and its #anchor names a heading of the page it points to), every ``mrta`` line of a
```bash block parses with the CLI's own argument parser, every picture is a curated sample under
renders/samples/, and no commit hash appears outside docs/results/ (the one place where a
measurement names the commit it was made at).
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
import subprocess
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
SAMPLES = ROOT / "renders" / "samples"
README_MAX_LINES = 250

# Pages another tool generates (the CLI reference and the scenario-key reference). Links to them
# are allowed to dangle ONLY while they do not exist; once a page exists it is checked like any
# other file (its anchors included). Empty this tuple once both pages are committed.
PENDING_GENERATED: tuple[str, ...] = ()

LINK = re.compile(r"(!?)\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
IMG_TAG = re.compile(r"<img\s[^>]*?src=\"([^\"]+)\"", re.I)
INLINE_CODE = re.compile(r"`+[^`]*`+")
FENCE = re.compile(r"^\s*(```+|~~~+)\s*([\w+-]*)")
HEX = re.compile(r"\b[0-9a-f]{7,40}\b")
MRTA = ("mrta", ".venv/bin/mrta")  # how a command line of the docs starts
SCHEME = re.compile(r"^[a-z][a-z0-9+.-]*:", re.I)


def pages() -> list[Path]:
    """Every Markdown page the checks cover."""
    return [README, ROOT / "CHANGELOG.md", *sorted(DOCS.rglob("*.md"))]


def rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


Lines = list[tuple[int, str]]  # (1-based line number, text)


def split_blocks(text: str) -> tuple[Lines, list[tuple[str, Lines]]]:
    """(prose lines, fenced blocks as (language, lines)), each line with its 1-based number."""
    prose, blocks = [], []
    fence, lang, body = None, "", []
    for number, line in enumerate(text.splitlines(), start=1):
        m = FENCE.match(line)
        if fence is None and m:
            fence, lang, body = m.group(1), m.group(2).lower(), []
        elif fence is not None and line.strip().startswith(fence[0] * len(fence)):
            blocks.append((lang, body))
            fence = None
        elif fence is not None:
            body.append((number, line))
        else:
            prose.append((number, line))
    return prose, blocks


def links(path: Path) -> list[tuple[int, str, bool]]:
    """(line, target, is_image) of every link and image outside code."""
    prose, _ = split_blocks(path.read_text(encoding="utf-8"))
    found = []
    for number, line in prose:
        bare = INLINE_CODE.sub("", line)
        found += [(number, m.group(2), bool(m.group(1))) for m in LINK.finditer(bare)]
        found += [(number, m.group(1), True) for m in IMG_TAG.finditer(bare)]
    return found


def relative(target: str) -> bool:
    return not SCHEME.match(target) and not target.startswith("//")


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = INLINE_CODE.sub(lambda m: m.group(0).strip("`"), heading.strip())
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading keeps its text
    text = re.sub(r"[^\w\- ]", "", text.lower())
    return text.replace(" ", "-")


@cache
def anchors(path: Path) -> frozenset[str]:
    prose, _ = split_blocks(path.read_text(encoding="utf-8"))
    seen: dict[str, int] = {}
    out = set()
    for _, line in prose:
        m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        base = slug(m.group(1))
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return frozenset(out)


def pending(target: Path) -> bool:
    """A generated page that is allowed to be missing (and only while it is missing)."""
    return not target.exists() and rel(target) in PENDING_GENERATED


def test_readme_is_a_front_page_not_a_notebook():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines; at most {README_MAX_LINES}"


def test_every_docs_page_is_in_the_index():
    index = DOCS / "README.md"
    listed = {(index.parent / t.partition("#")[0]).resolve() for _, t, _ in links(index)}
    expected = {p.resolve() for p in DOCS.rglob("*.md") if p != index}
    expected |= {(ROOT / name).resolve() for name in PENDING_GENERATED}
    missing = sorted(rel(p) for p in expected - listed)
    assert not missing, "pages docs/README.md does not list: " + ", ".join(missing)


@pytest.mark.parametrize("page", pages(), ids=rel)
def test_relative_links_resolve(page):
    broken = []
    for number, target, _ in links(page):
        if not relative(target):
            continue
        where, _, fragment = target.partition("#")
        dest = (page.parent / where).resolve() if where else page
        if pending(dest):
            continue
        if not dest.exists():
            broken.append(f"{rel(page)}:{number}: {target} (no such file)")
        elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
            broken.append(f"{rel(page)}:{number}: {target} (no heading #{fragment})")
    assert not broken, "\n".join(broken)


@pytest.mark.parametrize("page", pages(), ids=rel)
def test_pictures_are_curated_samples(page):
    wrong = []
    for number, target, image in links(page):
        if not image or not relative(target):
            continue
        dest = (page.parent / target.partition("#")[0]).resolve()
        if not dest.is_file() or not dest.is_relative_to(SAMPLES):
            wrong.append(f"{rel(page)}:{number}: {target} is not a file under renders/samples/")
    assert not wrong, "\n".join(wrong)


def mrta_lines(page: Path) -> Lines:
    """Every ``mrta ...`` command of the page's bash blocks: continuation lines joined, each
    ``&&``-separated part that starts with ``mrta`` or ``.venv/bin/mrta``."""
    _, blocks = split_blocks(page.read_text(encoding="utf-8"))
    out = []
    for lang, body in blocks:
        if lang not in ("bash", "sh", "shell", "console"):
            continue
        joined: Lines = []
        for number, line in body:
            if joined and joined[-1][1].endswith("\\"):
                joined[-1] = (joined[-1][0], joined[-1][1][:-1] + " " + line.strip())
            else:
                joined.append((number, line.strip()))
        for number, line in joined:
            for part in line.split("&&"):
                part = part.strip()
                if part.split(" ", 1)[0] in MRTA:
                    out.append((number, part))
    return out


def all_mrta_lines() -> list[tuple[str, int, str]]:
    return [(rel(p), n, line) for p in pages() for n, line in mrta_lines(p)]


@cache
def parser():
    try:
        from scenarios.cli.parser import build_parser
    except ImportError:  # the parser's module moved: the package still exports the builder
        from scenarios.cli import build_parser
    return build_parser()


MRTA_LINES = all_mrta_lines()


def test_the_docs_show_commands():
    assert len(MRTA_LINES) >= 20


@pytest.mark.parametrize(
    ("page", "number", "line"), MRTA_LINES, ids=[f"{p}:{n}" for p, n, _ in MRTA_LINES]
)
def test_mrta_lines_parse(page, number, line):
    argv = shlex.split(line, comments=True)[1:]  # the trailing '# comment' goes
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            parser().parse_args(argv)
    except SystemExit as exc:
        pytest.fail(f"{page}:{number}: `{line}` does not parse (exit {exc.code}): {err.getvalue()}")


@cache
def commit_hashes() -> tuple[str, ...]:
    try:
        out = subprocess.run(
            ["git", "log", "--all", "--format=%H"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        return ()
    return tuple(out.split())


def is_commit(word: str) -> bool:
    return any(h.startswith(word) for h in commit_hashes())


@pytest.mark.parametrize(
    "page", [p for p in pages() if not p.is_relative_to(DOCS / "results")], ids=rel
)
def test_no_commit_hash_outside_results(page):
    if not commit_hashes():
        pytest.skip("no git history here to tell a commit hash from other hex")
    found = []
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), start=1):
        for word in HEX.findall(line):
            has_digit = any(c.isdigit() for c in word)
            has_letter = any(c.isalpha() for c in word)
            if has_digit and has_letter and is_commit(word):
                found.append(f"{rel(page)}:{number}: {word}")
    assert not found, "commit hashes belong on docs/results/ pages only:\n" + "\n".join(found)


def test_the_python_example_of_the_maps_page_runs():
    """docs/maps.md's "From Python" block builds a scenario whose spatial table is a file's."""
    text = (ROOT / "docs" / "maps.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1
    names: dict = {}
    exec(compile(blocks[0], "docs/maps.md", "exec"), names)
    sc = names["scenario"]
    assert sc.spatial.map.endswith("tb3_sandbox.yaml")
    assert sc.robots[0].start_xy == pytest.approx((10.68, 9.52))  # origin (-10, -10)
    assert sc.spatial.sites[0][0] == pytest.approx((9.43, 11.87))
