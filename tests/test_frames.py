"""The one frame loop (granalytics.analysis.frames.map_frames): frame order, errors, and the same
results on a dask cluster of two worker processes as on one thread."""

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.analysis.frames import map_frames
from granalytics.base.errors import ParameterError
from granalytics.datasets import dataset_path


@pytest.fixture(scope="module")
def frames():
    run = ga.open_run(dataset_path("lab-cg3"))
    yield run.select(revolutions=(3.0, 3.3))
    run.close()


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed")
    import logging

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as cluster, distributed.Client(cluster) as c:
        yield c


def test_results_come_back_in_frame_order_on_threads(frames):
    serial = map_frames(frames, lambda s: s.time)
    threaded = map_frames(frames, lambda s: s.time, jobs=2)
    assert np.array_equal(serial[0], threaded[0]) and serial[1] == threaded[1]
    assert serial[1] == sorted(serial[1]) and len(serial[1]) == len(frames) > 3


@pytest.mark.slow
def test_a_dask_cluster_gives_the_serial_results(frames, client):
    serial = ga.run_stats(frames, "gna")
    on_cluster = ga.run_stats(frames, "gna", scheduler=client)
    pd.testing.assert_frame_equal(serial, on_cluster)
    tracks = ga.track_run(frames, "gna", scheduler=client)
    assert tracks.events.equals(ga.track_run(frames, "gna").events)
    table = ga.sensitivity(frames, [0.3, 0.6], [20.0], scheduler=client)
    pd.testing.assert_frame_equal(table, ga.sensitivity(frames, [0.3, 0.6], [20.0]))
    # a plain list of snapshots is sent to the workers
    snapshots = list(frames)[:3]
    assert map_frames(snapshots, lambda s: s.n_particles, scheduler=client)[1] == [s.n_particles for s in snapshots]
    # the tasks ran on the workers, each of which opened the run file itself
    assert len(client.scheduler_info()["workers"]) == 2


def test_jobs_and_a_scheduler_exclude_each_other(frames):
    with pytest.raises(ParameterError, match="exclude each other"):
        map_frames(frames, lambda s: s.time, jobs=2, scheduler="tcp://127.0.0.1:1")


@pytest.mark.parametrize("bad", [42, object()])
def test_a_scheduler_that_is_neither_an_address_nor_a_client_is_refused(frames, bad):
    with pytest.raises(ParameterError, match="scheduler must be an address"):
        map_frames(frames, lambda s: s.time, scheduler=bad)


def test_an_empty_selection_is_one_error(frames):
    with pytest.raises(ParameterError, match="no frames to analyse"):
        map_frames(frames.select(revolutions=(100.0, 101.0)), lambda s: s.time)


@pytest.mark.slow
def test_the_command_line_runs_frames_on_a_scheduler(frames, client, tmp_path, capsys):
    from granalytics.cli import main

    path = str(dataset_path("lab-cg3"))
    serial, remote = tmp_path / "serial.csv", tmp_path / "remote.csv"
    assert main(["stats", path, "--window", "3:3.3", "--out", str(serial), "--quiet"]) == 0
    assert main(["stats", path, "--window", "3:3.3", "--out", str(remote), "--quiet",
                 "--scheduler", client.scheduler.address]) == 0
    assert serial.read_text() == remote.read_text()


def test_the_command_line_refuses_jobs_with_a_scheduler(tmp_path, capsys):
    from granalytics.cli import main

    code = main(["stats", str(dataset_path("lab-cg3")), "--out", str(tmp_path / "t.csv"), "--jobs", "2",
                 "--scheduler", "tcp://127.0.0.1:1", "--quiet"])
    assert code == 2
    assert "exclude each other" in capsys.readouterr().err
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("bad", [None, 5, "run.h5"])
def test_frames_that_are_not_a_sequence_are_refused_by_every_analysis(bad):
    for call in (lambda: ga.run_stats(bad), lambda: ga.track_run(bad), lambda: ga.particle_table(bad)):
        with pytest.raises(ParameterError, match="frames must be a Run, a RunSlice or a sequence of Snapshot"):
            call()


def test_the_first_frames_compilation_is_not_counted_in_the_progress_rate(frames, monkeypatch):
    """The first frame's numba compilation made the ETA read 7 minutes: the bar's clock restarts
    after the first frame, so its rate is that of the frames after it."""
    import time

    import granalytics.analysis.frames as loop

    seen = {}

    class Recorded(loop.tqdm):
        def close(self):
            seen.update(self.format_dict)
            super().close()

    monkeypatch.setattr(loop, "tqdm", Recorded)
    calls = []

    def work(snapshot):
        calls.append(1)
        if len(calls) == 1:
            time.sleep(0.6)  # the first frame: compiling
        return snapshot.time

    map_frames(frames, work, progress=True)
    assert seen["n"] == seen["total"] == len(frames) and seen["initial"] == 1
    assert seen["elapsed"] < 0.4  # the 0.6 s of the first frame are not in the rate's clock


def test_the_bar_shows_no_time_left_from_the_compilation_and_never_goes_back_to_zero():
    import io
    import re
    import time

    from tqdm import tqdm

    from granalytics.analysis.frames import _advance

    out = io.StringIO()
    bar = tqdm(total=5, file=out, mininterval=0)
    time.sleep(0.3)  # the first frame: compiling
    for _ in range(5):
        _advance(bar)
    bar.close()
    shown = [int(m) for m in re.findall(r"\| (\d+)/5", out.getvalue())]
    assert shown == sorted(shown) and shown[0] == 0 and shown[1] == 1 and shown[-1] == 5
    first = out.getvalue().split("\r")[2]
    assert " 1/5 [00:00<?" in first  # no time left estimated from the compilation
