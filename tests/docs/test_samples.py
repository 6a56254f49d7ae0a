"""The curated samples and their table agree: every file under renders/samples/ has a command.

``scenarios.samples.SAMPLES`` names, for each figure, GIF and table the docs show, the ``mrta``
command that writes it. These checks run nothing: the folder and the table list the same files,
every command parses with the CLI's own parser and writes its sample where the table says, a
docs line that writes a sample is the table's command, and ``--dry-run`` prints the table.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from scenarios import samples
from scenarios.cli.parser import parse_command
from scenarios.samples import SAMPLES, SAMPLES_DIR, Command, Sample

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = list(dict.fromkeys(s.command for s in SAMPLES.values()))
INLINE_MRTA = re.compile(r"`(mrta [^`]*renders/samples/[^`]*)`")


def test_every_sample_file_has_an_entry():
    unlisted = sorted(samples.present(ROOT) - set(SAMPLES))
    assert not unlisted, f"files under {SAMPLES_DIR}/ with no entry in SAMPLES: {unlisted}"


def test_every_entry_has_its_file():
    missing = sorted(set(SAMPLES) - samples.present(ROOT))
    assert not missing, f"entries of SAMPLES whose file is missing: {missing}"


def test_the_table_covers_the_samples_the_docs_show():
    assert len(SAMPLES) >= 22
    assert all(not Path(n).is_absolute() and ".." not in Path(n).parts for n in SAMPLES)


def test_a_command_line_is_one_command():
    argvs = [c.argv for c in COMMANDS]
    assert len(set(argvs)) == len(argvs), "one command line with two costs in the table"


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: " ".join(c.argv[:2]))
def test_commands_parse(command):
    try:
        parse_command(command.argv)
    except ValueError as exc:
        pytest.fail(f"{command.line()} does not parse: {exc}")


@pytest.mark.parametrize("name", list(SAMPLES))
def test_each_command_writes_its_sample(name):
    sample = SAMPLES[name]
    out = sample.output().as_posix()
    if sample.file is None:  # the command writes the sample in place (a --gif path)
        assert out == f"{SAMPLES_DIR}/{name}"
    else:  # a folder of outputs, never renders/samples/ itself
        assert not out.startswith(SAMPLES_DIR + "/"), out
        assert Path(out).name == sample.file
    assert Path(out).suffix == Path(name).suffix
    assert sample.command.minutes > 0


def test_a_command_shown_beside_a_sample_is_the_tables():
    wrong = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for line in INLINE_MRTA.findall(page.read_text(encoding="utf-8")):
            argv = tuple(shlex.split(line)[1:])
            target = parse_command(argv).gif
            name = Path(target).as_posix().removeprefix(SAMPLES_DIR + "/")
            if name not in SAMPLES or SAMPLES[name].command.argv != argv:
                wrong.append(f"{page.relative_to(ROOT)}: `{line}`")
    assert not wrong, "docs commands that differ from scenarios.samples:\n" + "\n".join(wrong)


def test_dry_run_prints_the_table(capsys):
    assert samples.main(["--dry-run"]) == 0
    printed = [line for line in capsys.readouterr().out.splitlines() if not line.startswith("#")]
    runs = [tuple(shlex.split(line)[1:]) for line in printed if line.startswith("mrta ")]
    copies = {tuple(shlex.split(line)[1:]) for line in printed if line.startswith("cp ")}
    assert len(runs) + len(copies) == len(printed)
    assert sorted(runs) == sorted(c.argv for c in COMMANDS)  # each command once
    expected = set()
    for name, sample in SAMPLES.items():
        if sample.file is not None:
            expected.add((sample.output().as_posix(), f"{SAMPLES_DIR}/{name}"))
    assert copies == expected


def test_dry_run_copies_after_their_command(capsys):
    samples.main(["--dry-run"])
    current = None
    for line in capsys.readouterr().out.splitlines():
        if line.startswith("mrta "):
            current = tuple(shlex.split(line)[1:])
        elif line.startswith("cp "):
            dest = shlex.split(line)[2].removeprefix(SAMPLES_DIR + "/")
            assert SAMPLES[dest].command.argv == current, line


def test_list_prints_every_sample_with_its_command(capsys):
    assert samples.main(["--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == len(SAMPLES) + 1
    for line, (name, sample) in zip(lines, SAMPLES.items(), strict=False):
        assert line.split()[0] == name
        assert sample.command.line() in line
    assert lines[-1].startswith(f"{len(SAMPLES)} samples, {len(COMMANDS)} commands")


def test_only_selects_by_name_or_folder():
    assert samples.select(["paper/table2.md"]) == ["paper/table2.md"]
    assert samples.select(["renders/samples/faults/"]) == ["faults/study.md", "faults/faults.png"]
    assert samples.select(None) == list(SAMPLES)
    with pytest.raises(ValueError, match=r"did you mean 'paper/table2\.md'"):
        samples.select(["paper/table2.mdx"])


def test_only_runs_a_shared_command_once():
    runs = samples.commands(samples.select(["refusal"]))
    assert len(runs) == 1
    assert runs[0][1] == [n for n in SAMPLES if n.startswith("refusal/")]


def test_audit_reports_unlisted_and_missing_files(tmp_path):
    folder = tmp_path / SAMPLES_DIR
    for name in SAMPLES:
        if name != "paper/fig2_r5.png":
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_bytes(b"x")
    (folder / "paper" / "stray.png").write_bytes(b"x")
    (folder / "paper" / ".fig1_completion.png.123.tmp").write_bytes(b"x")  # a copy under way
    assert samples.audit(tmp_path) == [
        f"{SAMPLES_DIR}/paper/stray.png: no entry in scenarios.samples",
        f"{SAMPLES_DIR}/paper/fig2_r5.png: missing "
        "(python -m scenarios.samples --only paper/fig2_r5.png)",
    ]


def test_a_bad_command_does_not_parse():
    bad = Sample(Command.of("render paper_spatial --sets 2", 1))  # no --gif
    with pytest.raises(ValueError, match="--gif"):
        bad.output()
    with pytest.raises(ValueError, match="--out"):
        Sample(Command.of("study faults", 1), "faults.png").output()
