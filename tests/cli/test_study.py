"""``mrta study``: an unknown part is refused."""

from __future__ import annotations

from scenarios.cli import main


def test_study_only_rejects_an_unknown_part(capsys, tmp_path):
    assert main(["study", "refusal", "--only", "refusal_lod", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "refusal_lod" in err and "refusal_load" in err
    assert not any(tmp_path.iterdir())
