"""Issue 35.4: an ``--out`` that cannot be written is a bad argument — exit status 2 and one line
naming --out, for every command that writes, before any work (nothing is computed or created).

The unwritable places are paths under a regular file: they fail for root too (a chmod'ed folder
does not stop root)."""

from __future__ import annotations

import pytest

from torchirid.app import cli

#: the least each command needs to parse (its inputs need not exist: --out is checked first)
ARGS = {
    "spectrum": [],
    "gradients": [],
    "scatterogram": [],
    "film-table": [],
    "render-sphere": [],
    "thin-film": [],
    "fit-film": ["cube.npz"],
    "build-table": ["thin_film_reflectance", "--axis", "wavelength=400:700:3"],
    "fit-batch": ["film", "c.npz"],
    "montecarlo": ["--incident", "30", "0", "--exit", "30", "180"],
    "design": ["spec.toml"],
    "explore": [],
    "render-mitsuba": ["thin_film"],
}


def _commands_with_out():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sorted(name for name, p in sub.choices.items() if any(a.dest == "out" for a in p._actions))


def test_every_command_that_writes_is_covered():
    assert sorted(ARGS) == _commands_with_out()
    assert cli.FILE_OUTPUTS <= set(ARGS)


def _refused(capsys, command, out):
    with pytest.raises(SystemExit) as e:
        cli.main([command, *ARGS[command], "--out", str(out)])
    err = capsys.readouterr().err
    assert e.value.code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"torchirid {command}: error: --out "), err
    return lines[0]


@pytest.mark.parametrize("command", sorted(ARGS))
def test_out_under_a_file_exits_2_naming_out(tmp_path, capsys, command):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    name = "t.json" if command in cli.FILE_OUTPUTS else "out"
    line = _refused(capsys, command, blocker / "sub" / name)
    assert "is a file" in line and str(blocker) in line
    assert blocker.read_text() == "not a folder"


@pytest.mark.parametrize("command", sorted(ARGS))
def test_out_of_the_wrong_kind_exits_2(tmp_path, capsys, command):
    if command in cli.FILE_OUTPUTS:
        line = _refused(capsys, command, tmp_path)  # a folder where a file is wanted
        assert "is a folder" in line
    else:
        (tmp_path / "f").write_text("x")
        line = _refused(capsys, command, tmp_path / "f")  # a file where a folder is wanted
        assert "is a file" in line


def test_a_write_that_fails_after_the_checks_exits_1(tmp_path, capsys):
    (tmp_path / "spectrum.npz").mkdir()  # the file name is taken by a folder: only the write itself finds out
    status = cli.main(["spectrum", "--angles", "2", "--wavelengths", "500", "600", "3", "--out", str(tmp_path),
                       "--quiet"])
    assert status == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"torchirid spectrum: error: cannot write to --out {tmp_path}")
