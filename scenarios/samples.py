"""The curated samples: every file under ``renders/samples/`` and the command that makes it.

The README and ``docs/`` show figures, GIFs and tables from ``renders/samples/``. :data:`SAMPLES`
is their one table: each sample's command line (the one its page names) and, where the command
writes a folder, the file of that folder that becomes the sample. Regenerating runs each command
once (several samples may share one) in a temporary folder, with the same interpreter, and
copies the named outputs into place atomically, so a failed or interrupted run leaves the
committed samples as they were.

Usage::

    python -m scenarios.samples                       # regenerate all (hours: sweeps, studies)
    python -m scenarios.samples --list                # the table: sample, rough cost, command
    python -m scenarios.samples --only paper refusal/load.png   # some (a folder names its files)
    python -m scenarios.samples --dry-run             # the commands, as a script for the repo root

Every mode also reports a file under ``renders/samples/`` with no entry and an entry whose file
is missing (exit 1).
"""

from __future__ import annotations

import argparse
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from scenarios.cli.parser import parse_command
from sim.atomic import replacing
from sim.scenario.schema import did_you_mean

ROOT = Path(__file__).resolve().parents[1]
SAMPLES_DIR = "renders/samples"  # relative to the repository (and to a command's folder)


@dataclass(frozen=True, slots=True)
class Command:
    """One ``mrta`` command line that makes one or more samples.

    Attributes:
        argv: the arguments after ``mrta``, run from the repository root or a folder standing in
            for it (relative output paths resolve there).
        minutes: rough wall time on an idle 2-core machine, min.
    """

    argv: tuple[str, ...]
    minutes: float

    @classmethod
    def of(cls, text: str, minutes: float) -> Command:
        """The command ``mrta <text>`` (split as a shell would)."""
        return cls(tuple(shlex.split(text)), minutes)

    def line(self) -> str:
        """``mrta ...`` as one would type it."""
        return f"mrta {shlex.join(self.argv)}"


@dataclass(frozen=True, slots=True)
class Sample:
    """How one curated sample is made.

    Attributes:
        command: the command that writes it.
        file: the file of the command's ``--out`` folder that is the sample; None when the
            command writes the sample itself (``--gif renders/samples/...``).
    """

    command: Command
    file: str | None = None

    def output(self) -> Path:
        """The file the command writes, relative to the folder it runs in."""
        args = parse_command(self.command.argv)
        if self.file is None:
            return Path(args.gif)
        if getattr(args, "out", None) is None:
            raise ValueError(f"{self.command.line()}: give --out for {self.file}")
        return Path(args.out) / self.file


# Commands that make several samples (their pages: docs/results/*.md).
REPRODUCE = Command.of("reproduce --scenario paper --seeds 10 --out renders/paper", 0.5)
COMPARE = Command.of("compare paper_spatial --seeds 5 --out renders/compare/paper_spatial", 15)
COMPARE_FIVE = Command.of(
    "compare paper_spatial --allocators market,ql,expt,greedy,cbba --costs abstract,distance "
    "--seeds 5 --out renders/compare/paper_spatial_five",
    17,
)
STUDY_REFUSAL = Command.of("study refusal --out renders/study/refusal", 20)
STUDY_FAULTS = Command.of("study faults --out renders/study/faults", 1)

# sample path under renders/samples/ -> how it is made
SAMPLES: dict[str, Sample] = {
    # README.md
    "paper_spatial.gif": Sample(
        Command.of(
            "render paper_spatial --allocator expt --cost distance --seed 0 --sets 2 "
            "--gif renders/samples/paper_spatial.gif",
            1,
        )
    ),
    # docs/results/paper.md
    "paper/fig1_completion.png": Sample(REPRODUCE, "fig1_completion.png"),
    "paper/fig2_r5.png": Sample(REPRODUCE, "fig2_r5.png"),
    "paper/table2.md": Sample(REPRODUCE, "table2.md"),
    "paper/tradeoff.png": Sample(REPRODUCE, "tradeoff.png"),
    # docs/results/compare.md
    "paper_spatial/compare.md": Sample(COMPARE, "compare.md"),
    "paper_spatial/compare.png": Sample(COMPARE, "compare.png"),
    "paper_spatial/compare_five.md": Sample(COMPARE_FIVE, "compare.md"),
    "paper_spatial/compare_five.png": Sample(COMPARE_FIVE, "compare.png"),
    "paper_spatial/run_expt_distance.png": Sample(
        Command.of(
            "run paper_spatial --allocator expt --cost distance --seed 0 --out renders/run", 0.6
        ),
        "spatial.png",
    ),
    # docs/results/faults.md
    "faults/study.md": Sample(STUDY_FAULTS, "study.md"),
    "faults/faults.png": Sample(STUDY_FAULTS, "faults.png"),
    # docs/results/refusal.md
    "refusal/study.md": Sample(STUDY_REFUSAL, "study.md"),
    "refusal/load.png": Sample(STUDY_REFUSAL, "load.png"),
    "refusal/losses.png": Sample(STUDY_REFUSAL, "losses.png"),
    "refusal/frontier.png": Sample(STUDY_REFUSAL, "frontier.png"),
    "refusal/spatial.png": Sample(STUDY_REFUSAL, "spatial.png"),
    # docs/results/avoidance.md
    "avoidance/circle20.gif": Sample(
        Command.of(
            "hardcase circle --robots 20 --gif renders/samples/avoidance/circle20.gif "
            "--frames 100 --fps 10 --size 360",
            0.2,
        )
    ),
    "avoidance/paper_spatial_orca.gif": Sample(
        Command.of(
            "render paper_spatial --avoidance orca --sets 1 --allocator expt "
            "--gif renders/samples/avoidance/paper_spatial_orca.gif --frames 150 --fps 10 "
            "--size 480",
            0.5,
        )
    ),
    "avoidance/avoidance_sweep.png": Sample(
        Command.of("sweep avoidance --out renders/sweeps/avoidance", 10), "avoidance.png"
    ),
    "avoidance/avoidance_layouts.png": Sample(
        Command.of("sweep avoidance_layouts --out renders/sweeps/avoidance_layouts", 25),
        "avoidance.png",
    ),
    "avoidance/stalls_warehouse.png": Sample(
        Command.of(
            "run warehouse --allocator market --cost abstract --seed 0 --out renders/wh", 0.5
        ),
        "stalls.png",
    ),
    # the depot map's GIF (the README's quick tour, docs/maps.md)
    "depot.gif": Sample(
        Command.of(
            "render depot --allocator expt --cost distance --seed 0 --sets 1 "
            "--gif renders/samples/depot.gif",
            0.5,
        )
    ),
}


def commands(names: Iterable[str]) -> list[tuple[Command, list[str]]]:
    """The distinct commands that make ``names``, each with its samples in table order; the
    quickest first, so the cheap samples land before the sweeps and studies."""
    wanted = set(names)
    groups: dict[Command, list[str]] = {}
    for name, sample in SAMPLES.items():
        if name in wanted:
            groups.setdefault(sample.command, []).append(name)
    return sorted(groups.items(), key=lambda group: group[0].minutes)


def select(only: Sequence[str] | None) -> list[str]:
    """The sample names ``only`` means (a name, or a folder for all of its samples), in table
    order; all of them without it. Raises ValueError on a word that matches no sample."""
    if not only:
        return list(SAMPLES)
    chosen: set[str] = set()
    for word in only:
        word = word.removeprefix(SAMPLES_DIR + "/").rstrip("/")
        found = {n for n in SAMPLES if n == word or n.startswith(word + "/")}
        if not found:
            raise ValueError(f"no sample {word!r}{did_you_mean(word, SAMPLES)} (see --list)")
        chosen |= found
    return [n for n in SAMPLES if n in chosen]


def present(root: Path = ROOT) -> set[str]:
    """The sample files under ``root/renders/samples/`` (hidden files, such as a copy in
    progress, left out)."""
    folder = root / SAMPLES_DIR
    found = (p.relative_to(folder) for p in folder.rglob("*") if p.is_file())
    return {p.as_posix() for p in found if not any(part.startswith(".") for part in p.parts)}


def audit(root: Path = ROOT) -> list[str]:
    """One line per disagreement between :data:`SAMPLES` and ``root/renders/samples/``: a
    file with no entry, or an entry whose file is missing."""
    files = present(root)
    lines = [
        f"{SAMPLES_DIR}/{n}: no entry in scenarios.samples" for n in sorted(files - set(SAMPLES))
    ]
    lines += [
        f"{SAMPLES_DIR}/{n}: missing (python -m scenarios.samples --only {n})"
        for n in SAMPLES
        if n not in files
    ]
    return lines


def cost_text(minutes: float) -> str:
    """A rough time as people say it: '<1 min', '~10 min', '~1.5 h'."""
    if minutes < 1:
        return "<1 min"
    if minutes < 90:
        return f"~{minutes:.0f} min"
    return f"~{minutes / 60:.1f} h"


def table_lines(names: Sequence[str]) -> list[str]:
    """``--list``: one line per sample (name, rough cost of its command, the command, and the
    file of its folder that is the sample), then the total, each shared command counted once."""
    width = max(len(n) for n in names)
    lines = []
    for name in names:
        s = SAMPLES[name]
        its = f"  -> {s.file}" if s.file else ""
        lines.append(f"{name:<{width}}  {cost_text(s.command.minutes):>7}  {s.command.line()}{its}")
    runs = commands(names)
    total = sum(command.minutes for command, _ in runs)
    lines.append(f"{len(names)} samples, {len(runs)} commands, {cost_text(total)} in all")
    return lines


def script_lines(names: Sequence[str]) -> list[str]:
    """``--dry-run``: the commands and copies that make ``names``, as a shell script to run from
    the repository root (what :func:`regenerate` does, less the temporary folder)."""
    lines = ["# from the repository root"]
    for command, group in commands(names):
        lines.append(command.line())
        for name in group:
            source, dest = SAMPLES[name].output().as_posix(), f"{SAMPLES_DIR}/{name}"
            if source != dest:
                lines.append(f"cp {shlex.quote(source)} {shlex.quote(dest)}")
    return lines


def regenerate(names: Sequence[str], root: Path = ROOT) -> int:
    """Make ``names`` under ``root/renders/samples/``: each command once, in a temporary folder,
    by this interpreter's ``python -m scenarios.cli``, its outputs copied into place atomically.
    Prints one line per sample with its command's wall time and returns the number of samples
    that failed (those stay as they were; the command's own output goes to stderr)."""
    failed = 0
    for command, group in commands(names):
        with tempfile.TemporaryDirectory(prefix="mrta-samples-") as tmp:
            work = Path(tmp)
            for name in group:  # a --gif's folder must exist; mrta makes an --out folder
                (work / SAMPLES[name].output()).parent.mkdir(parents=True, exist_ok=True)
            start = time.perf_counter()
            done = subprocess.run(
                [sys.executable, "-m", "scenarios.cli", *command.argv],
                cwd=work,
                stdout=sys.stderr,
                check=False,
            )
            seconds = time.perf_counter() - start
            for name in group:
                source = work / SAMPLES[name].output()
                if done.returncode != 0 or not source.is_file():
                    why = f"exit {done.returncode}" if done.returncode else f"no {source.name}"
                    print(f"{SAMPLES_DIR}/{name}: FAILED ({why}, {seconds:.0f} s)", flush=True)
                    failed += 1
                    continue
                dest = root / SAMPLES_DIR / name
                dest.parent.mkdir(parents=True, exist_ok=True)
                with replacing(dest) as part:
                    shutil.copyfile(source, part)
                print(f"{SAMPLES_DIR}/{name}: {seconds:.0f} s ({command.line()})", flush=True)
    return failed


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate, list or print the samples' commands. Exit 1 on a failed command or a
    disagreement between the table and the folder (reported on stderr), 2 on a bad name."""
    ap = argparse.ArgumentParser(
        prog="python -m scenarios.samples",
        description=f"Regenerate the curated samples under {SAMPLES_DIR}/ from their commands.",
    )
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--list", action="store_true", help="print the table: sample, cost, command")
    mode.add_argument("--dry-run", action="store_true", help="print the commands, run nothing")
    ap.add_argument(
        "--only",
        nargs="+",
        metavar="NAME",
        help="these samples (paths under renders/samples/, or a folder for all of its files)",
    )
    args = ap.parse_args(argv)
    try:
        names = select(args.only)
    except ValueError as exc:
        ap.error(str(exc))
    failed = 0
    if args.list:
        print("\n".join(table_lines(names)))
    elif args.dry_run:
        print("\n".join(script_lines(names)))
    else:
        failed = regenerate(names)
    problems = audit()
    for line in problems:
        print(line, file=sys.stderr)
    return 1 if failed or problems else 0


if __name__ == "__main__":
    sys.exit(main())
