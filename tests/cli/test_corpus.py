"""The malformed-scenario corpus: each file gives one clear line, exit code 2, no traceback.

Every file in ``tests/scenarios/corpus/`` starts with ``# expect: <text>``: ``mrta validate``'s
message must name the file and contain that text (which names the key path and the problem).
That every check of the loader has a corpus file is asked in
``tests/scenarios/test_python_door.py``."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenarios.cli import main

CORPUS = sorted((Path(__file__).parents[1] / "scenarios" / "corpus").glob("*.toml"))


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
