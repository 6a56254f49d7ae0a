"""The suite's own setup (tests/conftest.py): what it measures is printed when the tests run on
several workers."""

from __future__ import annotations

from pathlib import Path

import pytest

CONFTEST = Path(__file__).resolve().parent / "conftest.py"


@pytest.mark.slow
def test_report_lines_written_in_workers_are_printed_after_the_summary(pytester):
    pytester.makeconftest(CONFTEST.read_text())
    pytester.makepyfile(
        test_one="def test_one(report_line):\n    report_line('first line measured')\n",
        test_two="def test_two(report_line):\n    report_line('second line measured')\n",
    )
    args = ("-n", "2", "--dist", "loadfile", "-p", "no:cacheprovider")
    result = pytester.runpytest_subprocess(*args)
    result.assert_outcomes(passed=2)
    out = result.stdout.str()
    assert out.count("measured by the tests") == 1
    assert "first line measured" in out and "second line measured" in out
