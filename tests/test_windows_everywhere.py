"""One way to give a window in every command: each option that takes a window in revolutions
(R0:R1) has a twin in seconds (T0:T1), and the seconds select the frames the revolutions do."""

import argparse

import pytest

import granalytics as ga
from granalytics.cli import build_parser, main
from granalytics.datasets import dataset_path


def _commands():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


def test_every_revolution_window_has_a_time_twin():
    seen = 0
    for name, command in _commands().items():
        options = {a.metavar: a.option_strings[0] for a in command._actions if a.option_strings}
        revolution = [a for a in command._actions if a.metavar == "R0:R1"]
        times = [a for a in command._actions if a.metavar == "T0:T1"]
        assert len(revolution) == len(times), f"{name}: {len(revolution)} revolution windows, {len(times)} in seconds"
        for a in revolution:
            seen += 1
            twin = {"--window": "--window-time", "--window-rev": "--window-time", "--fit-window": "--fit-window-time",
                    "--predict": "--predict-time", "--full-window": "--full-window-time"}[a.option_strings[0]]
            assert twin in {o for t in times for o in t.option_strings}, f"{name}: {a.option_strings[0]} has no {twin}"
    assert seen >= 12 and options is not None


def _seconds(revolutions, omega):
    import math

    return ":".join(f"{r * 2 * math.pi / abs(omega):.12g}" for r in revolutions)


@pytest.mark.parametrize("command", ["sensitivity", "compare-cg", "compare-methods"])
def test_a_time_window_gives_the_revolution_windows_result(command, tmp_path, capsys):
    run = str(dataset_path("lab-cg3"))
    with ga.open_run(run) as r:
        omega = r.meta.drum_omega
    extra = {"sensitivity": ["--c-agg", "0.5,0.6", "--a-agg-deg", "20"],
             "compare-cg": ["--out", str(tmp_path / "cg"), "--quiet"],
             "compare-methods": ["--methods", "gna,sieve"]}[command]
    inputs = [run, str(dataset_path("lab-cg2"))] if command == "compare-cg" else [run]
    outputs = []
    for window in (["--window", "3:4"], ["--window-time", _seconds((3, 4), omega)]):
        if command == "compare-cg":
            extra[1] = str(tmp_path / f"cg{len(outputs)}")
        assert main([command, *inputs, *window, *extra]) == 0
        outputs.append(capsys.readouterr().out.replace(str(tmp_path / "cg1"), str(tmp_path / "cg0")))
    assert outputs[0] == outputs[1]
    with pytest.raises(SystemExit) as exit_:
        main([command, *inputs, "--window", "3:4", "--window-time", "1:2", *extra])
    assert exit_.value.code == 2 and "not allowed with argument" in capsys.readouterr().err


def test_frame_windows_in_seconds_select_the_same_frames(tmp_path, capsys):
    run = str(dataset_path("lab-cg3"))
    with ga.open_run(run) as r:
        omega = r.meta.drum_omega
    outputs = []
    for flags in (["--window-rev", "3:3.5"], ["--window-time", _seconds((3, 3.5), omega)]):
        out = tmp_path / f"table{len(outputs)}.csv"
        assert main(["table", run, *flags, "--out", str(out), "--quiet"]) == 0
        outputs.append(out.read_text())
    assert outputs[0] == outputs[1] and len(outputs[0].splitlines()) > 111 * 5
    capsys.readouterr()
    assert main(["table", run, "--window-rev", "3:3.5", "--window-time", "1:2", "--out", str(tmp_path / "x.csv"),
                 "--quiet"]) == 2
    assert "give one" in capsys.readouterr().err


def test_a_window_past_the_run_names_what_it_covers_and_the_other_unit(capsys):
    assert main(["sensitivity", str(dataset_path("lab-cg3")), "--window", "50:60", "--c-agg", "0.6",
                 "--a-agg-deg", "20"]) == 2
    err = capsys.readouterr().err
    assert "the run covers [0, 6] revolutions" in err and "--window-time T0:T1 in seconds" in err
