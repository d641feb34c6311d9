import pytest

from sim.cli import main


@pytest.mark.parametrize(
    "args, words",
    [
        (["--gamma", "-1"], "surface_tension"),
        (["--alpha", "0.5"], "alpha"),
        (["--threads", "99"], "--threads"),
        (["--revolutions", "0"], "--revolutions"),
        (["--resume"], "no checkpoint"),
    ],
)
def test_bad_parameters_give_one_line_and_exit_2(tmp_path, capsys, args, words):
    argv = ["run", "--preset", "lab-cg3", "--revolutions", "1", "--out", str(tmp_path / "r.h5"), "--quiet"] + args
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sim: error:") and words in err[0]


def test_presets_are_listed(capsys):
    assert main(["presets"]) == 0
    out = capsys.readouterr().out
    assert "paper-cg1" in out and "120000 particles" in out and "lab-cg3" in out


def test_unknown_preset_is_an_argparse_error():
    with pytest.raises(SystemExit) as exit_:
        main(["run", "--preset", "lab-cg9", "--revolutions", "1", "--out", "x.h5"])
    assert exit_.value.code == 2
