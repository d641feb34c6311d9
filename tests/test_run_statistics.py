"""A run's statistics kept in place of its frames (RunStatistics): written and read back unchanged,
joined from parts, and compared by compare_cg exactly as the run file they were made of."""

import os

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics import ParameterError, RunStatistics

DATA = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "datasets")
CG3, CG2 = os.path.join(DATA, "lab-cg3.h5"), os.path.join(DATA, "lab-cg2.h5")


@pytest.fixture(scope="module")
def kept():
    with ga.open_run(CG3) as run:
        return RunStatistics.of_frames(run, run.meta, path="lab-cg3 kept")


def test_the_statistics_are_the_runs_frame_by_frame_and_come_back_unchanged_from_disk(kept, tmp_path):
    plain, sizes = ga.run_stats(ga.open_run(CG3), return_sizes=True)
    assert len(kept) == len(plain) == 121 and kept.timeseries["frame"].tolist() == list(range(121))
    assert np.allclose(kept.timeseries["yield_fraction"], plain["yield_fraction"])
    assert all(np.array_equal(a, b) for a, b in zip(kept.sizes, sizes))
    assert kept.params["c_agg"] == 0.6 and kept.params["cohesion"] == "acting" and "backend" not in kept.params
    ga.save(kept, tmp_path / "stats")
    with pytest.raises(ParameterError, match="exists"):
        ga.save(kept, tmp_path / "stats")
    back = RunStatistics.read(tmp_path / "stats")
    pd.testing.assert_frame_equal(back.timeseries, kept.timeseries, check_dtype=False)
    assert all(np.array_equal(np.sort(a), np.sort(b)) for a, b in zip(back.sizes, kept.sizes))
    assert back.meta.to_dict() == kept.meta.to_dict() and back.params == kept.params and back.method == "gna"
    with pytest.raises(ParameterError, match="not kept run statistics"):
        RunStatistics.read(tmp_path / "nothing")


def test_statistics_kept_in_parts_join_into_the_whole_runs(kept):
    with ga.open_run(CG3) as run:
        first = RunStatistics.of_frames(run[:50], run.meta)
        second = RunStatistics.of_frames(run[50:], run.meta, frame_indices=range(50, 121))
    joined = second.join(first)
    pd.testing.assert_frame_equal(joined.timeseries, kept.timeseries)
    assert all(np.array_equal(a, b) for a, b in zip(joined.sizes, kept.sizes))
    with pytest.raises(ParameterError, match="frame 0 is in"):
        joined.join(first)
    with ga.open_run(CG2) as run:
        other = RunStatistics.of_frames(run[:2], run.meta, frame_indices=[200, 201])
    with pytest.raises(ParameterError, match="statistics of another run"):
        joined.join(other)


def test_joined_statistics_carry_the_metadata_of_the_run_as_it_stood_last():
    """The part made last (a finished run's wall time) gives the metadata; what only the first
    recorded (the settling) stays; a part's frames are numbered from its first frame."""
    from granalytics import RunMeta

    with ga.open_run(CG3) as run:
        early, late = RunMeta.from_dict(run.meta.to_dict()), RunMeta.from_dict(run.meta.to_dict())
        early.provenance = {k: v for k, v in early.provenance.items() if k != "wall_time_s"} | {"settle_wall_time_s": 5.0}
        late.provenance = {k: v for k, v in late.provenance.items() if not k.startswith("settle")} | {
            "wall_time_s": 99.0, "first_frame": 50}
        first = RunStatistics.of_frames(run[:50], early)
        second = RunStatistics.of_frames([run[k] for k in range(50, 121)], late)
    assert second.timeseries["frame"].tolist() == list(range(50, 121))
    for joined in (first.join(second), second.join(first)):
        assert joined.meta.provenance["wall_time_s"] == 99.0 and joined.meta.provenance["settle_wall_time_s"] == 5.0
        assert "first_frame" not in joined.meta.provenance and joined.timeseries["frame"].tolist() == list(range(121))


def test_compare_cg_says_when_kept_statistics_are_of_an_unfinished_run(kept):
    import dataclasses
    import warnings

    from granalytics import RunMeta

    running = RunMeta.from_dict(kept.meta.to_dict())
    running.provenance = {k: v for k, v in running.provenance.items() if k != "wall_time_s"}
    assert kept.unfinished is None and "reach frame 120" in dataclasses.replace(kept, meta=running).unfinished
    for statistics, warned in ((dataclasses.replace(kept, meta=running), True), (kept, False)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ga.compare_cg([statistics, CG2], window=(3.0, 6.0))
        said = [str(w.message) for w in caught if "unfinished" in str(w.message)]
        assert said == (["lab-cg3 kept: statistics of an unfinished run: the simulator recorded no end (no wall time); "
                         "the statistics reach frame 120; its steady state is that of the frames kept"] if warned else [])


def test_compare_cg_takes_kept_statistics_as_the_run_they_were_made_of(kept):
    with pytest.warns(UserWarning):
        from_files = ga.compare_cg([CG2, CG3])
    with pytest.warns(UserWarning):
        from_kept = ga.compare_cg([CG2, kept])
    columns = [c for c in from_files.table if c.endswith(("_mean", "_sem", "_rel_dev")) or c == "ks_distance"]
    pd.testing.assert_frame_equal(from_kept.table[columns], from_files.table[columns])
    pd.testing.assert_frame_equal(from_kept.distributions, from_files.distributions)
    assert from_kept.runs.loc[1, "path"] == "lab-cg3 kept"
    # the kept statistics cannot be identified again under other thresholds
    with pytest.warns(UserWarning), pytest.raises(ParameterError, match="c_agg=0.6.*asked for 'gna' \\(c_agg=0.5\\)"):
        ga.compare_cg([CG2, kept], c_agg=0.5)


def test_compare_cg_on_the_command_line_reads_a_folder_of_kept_statistics(kept, tmp_path, capsys):
    from granalytics.cli import main

    ga.save(kept, tmp_path / "cg3-stats")
    assert main(["compare-cg", CG2, CG3, "--out", str(tmp_path / "files"), "--quiet"]) == 0
    assert main(["compare-cg", CG2, str(tmp_path / "cg3-stats"), "--out", str(tmp_path / "kept"), "--quiet"]) == 0
    files, kept_table = (pd.read_csv(tmp_path / name / "cg_table.csv") for name in ("files", "kept"))
    assert np.allclose(kept_table["yield_fraction_mean"], files["yield_fraction_mean"])
    assert np.allclose(kept_table["ks_distance"], files["ks_distance"], equal_nan=True)
    # a threshold grid identifies the granules again: it needs the frames
    capsys.readouterr()
    code = main(["compare-cg", CG2, str(tmp_path / "cg3-stats"), "--c-agg", "0.4,0.6", "--out", str(tmp_path / "grid"),
                 "--quiet"])
    assert code == 2 and "holds statistics kept at one threshold pair" in capsys.readouterr().err


def test_a_resave_keeps_every_file_in_place_and_renames_the_frames_in_last(kept, tmp_path, monkeypatch):
    """A process killed during the save (a stop during `keep`) left frames.csv with frames whose
    sizes were not yet in sizes.csv (read back as no granules, never made again), or no sizes.csv
    at all (moved aside): every later read failed."""
    import granalytics.report.files as files

    folder = tmp_path / "kept"
    with ga.open_run(ga.datasets.dataset_path("lab-cg3")) as run:
        ga.save(RunStatistics.of_frames(run[:3], run.meta), folder)
    targets = [str(folder / name) for name in ("frames.csv", "sizes.csv", "meta.json")]
    renamed, missing = [], []
    real = os.replace

    def replace(src, dst):
        missing.extend(t for t in targets if not os.path.exists(t))  # what a kill at this moment leaves
        renamed.append(os.path.basename(dst))
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    ga.save(kept, folder, overwrite=True)
    assert missing == []
    assert [name for name in renamed if name in ("frames.csv", "sizes.csv", "meta.json")][-1] == "frames.csv"
    back = RunStatistics.read(folder)
    assert back.timeseries.equals(kept.timeseries)
