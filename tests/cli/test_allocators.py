"""Bad allocator names: one clear line from the registry and from ``mrta run`` (exit 2)."""

from __future__ import annotations

import re

import pytest

from learning.registry import AllocatorError, allocator_class
from scenarios.cli import main


@pytest.mark.parametrize(
    "name, message",
    [
        ("grredy", "did you mean 'greedy'"),
        ("nosuchmodule:X", "cannot import 'nosuchmodule'"),
        ("json:Nope", "json has no 'Nope'"),
        ("json:JSONDecoder", "reset, begin_set, allocate"),
        ("json", "unknown allocator 'json'"),
    ],
)
def test_bad_allocator_names_are_one_clear_line(name, message, capsys, tmp_path):
    with pytest.raises(AllocatorError, match=re.escape(message)):
        allocator_class(name)
    with pytest.raises(SystemExit) as stop:  # argparse: one line, exit code 2
        main(["run", "paper", "--allocator", name, "--out", str(tmp_path / "o")])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert not (tmp_path / "o").exists()
