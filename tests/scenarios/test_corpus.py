"""The malformed-scenario corpus: each file gives one clear line, exit code 2, no traceback.

Every file in ``corpus/`` starts with ``# expect: <text>``: the message must name the file and
contain that text (which names the key path and the problem).
"""

from __future__ import annotations

import ast
import os
import re
from pathlib import Path

import pytest

from scenarios import loader
from scenarios.cli import main
from scenarios.loader import ScenarioError
from sim.scenario import core, schema, spatial
from sim.spatial import layout

CORPUS = sorted((Path(__file__).parent / "corpus").glob("*.toml"))


def expected(path: Path) -> str:
    first = path.read_bytes().split(b"\n", 1)[0].decode()
    assert first.startswith("# expect: "), path
    return first.removeprefix("# expect: ")


def test_corpus_is_large_enough():
    assert len(CORPUS) >= 30


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_malformed_scenario(path, capsys):
    code = main(["validate", str(path)])
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1, err
    assert "Traceback" not in err
    assert err.startswith(f"mrta: error: {path}: "), err
    assert expected(path) in err, err


def pattern(node: ast.expr) -> str:
    """Regex for the text a message argument can produce: literal parts exact, the rest any."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return re.escape(node.value)
    if isinstance(node, ast.JoinedStr):
        return "".join(pattern(part) for part in node.values)
    return ".*?"


def loader_checks() -> list[tuple[str, str]]:
    """Every validation check of the loader: (where, regex of the line it gives).

    A check is a call of ``fail(key, problem)`` in the loader (``scenarios/loader.py``), the
    specs that check themselves (``sim/scenario/``) and the layout check
    (``sim/spatial/layout.py``).
    """
    out = []
    for module in (loader, schema, core, spatial, layout):
        path = Path(module.__file__)
        for func in ast.walk(ast.parse(path.read_text())):
            if not isinstance(func, ast.FunctionDef):
                continue
            for call in ast.walk(func):
                if not (
                    isinstance(call, ast.Call)
                    and isinstance(call.func, ast.Name)
                    and call.func.id == "fail"
                ):
                    continue
                key, problem = call.args[:2]
                where = f"{path.name}:{call.lineno} ({func.name})"
                out.append((where, f": {pattern(key)}: {pattern(problem)}"))
    return out


def corpus_lines() -> list[str]:
    lines = []
    for path in CORPUS:
        with pytest.raises(ScenarioError) as info:
            loader.load_scenario(path)
        lines.append(str(info.value))
    return lines


@pytest.mark.skipif(
    "MUTANT_UNDER_TEST" in os.environ, reason="reads the loader's source, which mutmut rewrites"
)
def test_every_loader_check_has_a_corpus_file(tmp_path):
    """Every check is reached by a corpus file, or (a problem no file can express, a door other
    than a file) by a case of ``test_python_door.py``."""
    from tests.scenarios.test_python_door import door_lines

    checks = loader_checks()
    assert len(checks) >= 60  # the walk finds the checks (a refactor that hides them fails here)
    lines = corpus_lines() + [f"python: {line}" for line in door_lines(tmp_path)]
    missing = [w for w, rx in checks if not any(re.search(rx, line) for line in lines)]
    assert not missing, f"loader checks without a file in tests/scenarios/corpus/: {missing}"
