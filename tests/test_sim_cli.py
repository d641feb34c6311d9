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


@pytest.mark.slow
def test_a_killed_run_resumes_from_its_checkpoint_bit_identically(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    import numpy as np

    import granalytics as ga

    args = [sys.executable, "-m", "sim", "run", "--preset", "lab-cg3", "--revolutions", "0.1",
            "--frame-every-rev", "0.01", "--checkpoint-every", "3", "--quiet"]
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    subprocess.run(args + ["--out", str(full)], check=True, capture_output=True)
    proc = subprocess.Popen(args + ["--out", str(part)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    marker = f"{part}.ckpt.npz"  # one file, renamed into place when complete
    deadline = time.time() + 120
    while not os.path.exists(marker) and time.time() < deadline:
        time.sleep(0.02)
    assert proc.poll() is None, "the run ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    subprocess.run(args + ["--out", str(part), "--resume"], check=True, capture_output=True)
    with ga.open_run(full) as a, ga.open_run(part) as b:
        assert len(a) == len(b) == 10  # 0.1 revolution, a frame every 3 491 steps
        for fa, fb in zip(a, b):
            for name in ("time", "ids", "position", "velocity", "angular_velocity", "film_volume",
                         "contact_i", "contact_j", "f_cap", "f_normal", "gap", "bridge_volume"):
                assert np.array_equal(getattr(fa, name), getattr(fb, name)), name
