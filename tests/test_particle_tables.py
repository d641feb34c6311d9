"""The tidy per-particle table: one row per particle and frame, granule track ids that persist."""

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.cli import main
from granalytics.datasets.synthetic import write_synthetic_run
from granalytics.analysis.particle_tables import granule_tracks


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    return write_synthetic_run(tmp_path_factory.mktemp("table") / "run.h5", n_particles=200, revolutions=1.0,
                               frames_per_revolution=8, seed=4)


def test_particle_table_rows_columns_and_persistent_track_ids(run_file):
    with ga.open_run(run_file) as run:
        frames = run.select(revolutions=(0.25, 1.0))
        table = ga.particle_table(frames, c_agg=0.5)
        n_frames = len(frames)
        first = frames[0]
    assert list(table.columns) == list(ga.PARTICLE_COLUMNS)
    assert len(table) == 200 * n_frames and table.frame.nunique() == n_frames
    row = table[(table.frame == table.frame.min()) & (table.id == first.ids[5])].iloc[0]
    assert row.x == first.position[5, 0] and row.radius == first.radius[5]
    free = table.granule < 0
    assert (table.granule_track[free] == -1).all() and (table.granule_track[~free] >= 0).all()
    # within a frame a track id is one granule, and one granule one track id
    per_frame = table[~free].groupby(["frame", "granule"]).granule_track.nunique()
    assert (per_frame == 1).all()
    assert (table[~free].groupby(["frame", "granule_track"]).granule.nunique() == 1).all()
    # a track id that appears in several frames is the tracker's: the same id in the tracks table
    labels, tracks = granule_tracks(ga.open_run(run_file).select(revolutions=(0.25, 1.0)), c_agg=0.5)
    lived = tracks.tracks.set_index("track")
    for track, part in table[~free].groupby("granule_track"):
        sizes = part.groupby("frame").size().tolist()
        assert sizes == list(lived.loc[track, "sizes"])


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_table_command_writes_the_same_rows(run_file, tmp_path, capsys, suffix):
    out = tmp_path / f"particles{suffix}"
    assert main(["table", run_file, "--out", str(out), "--window-rev", "0.25:1", "--c-agg", "0.5", "--quiet"]) == 0
    written = pd.read_parquet(out) if suffix == ".parquet" else pd.read_csv(out)
    with ga.open_run(run_file) as run:
        expected = ga.particle_table(run.select(revolutions=(0.25, 1.0)), c_agg=0.5)
    pd.testing.assert_frame_equal(written, expected, check_dtype=False)
    assert main(["table", run_file, "--out", str(out), "--quiet"]) == 2  # exists, no --overwrite
    assert "exists" in capsys.readouterr().err


def test_identify_writes_the_same_granule_track_ids(run_file, tmp_path):
    import h5py

    out = tmp_path / "labels.h5"
    assert main(["identify", run_file, "--out", str(out), "--c-agg", "0.5", "--quiet"]) == 0
    with ga.open_run(run_file) as run:
        table = ga.particle_table(run, c_agg=0.5)
    with h5py.File(out, "r") as f:
        tracks = f["granule_track"][:]
    assert np.array_equal(tracks.ravel(), table.granule_track.to_numpy())


def test_granule_table_carries_the_same_track_ids(run_file):
    with ga.open_run(run_file) as run:
        particles = ga.particle_table(run, c_agg=0.5)
        granules = ga.granule_track_table(run, c_agg=0.5)
    members = particles[particles.granule >= 0].groupby(["frame", "granule"]).agg(
        track=("granule_track", "first"), size=("id", "size"))
    joined = granules.set_index(["frame", "granule"]).join(members)
    assert (joined["granule_track"] == joined["track"]).all() and len(joined) == len(members)
    size_column = "size" if "size" in granules else "n_particles"
    assert (joined[size_column].to_numpy() == joined.iloc[:, -1].to_numpy()).all()


def test_track_ids_follow_the_main_branch_by_default_and_the_strict_rule_on_request(run_file, tmp_path):
    import h5py

    with ga.open_run(run_file) as run:
        main_ids = ga.particle_table(run, c_agg=0.5)
        strict = ga.particle_table(run, c_agg=0.5, continuation="strict")
        pd.testing.assert_frame_equal(main_ids, ga.particle_table(run, c_agg=0.5, continuation="main"))
        granules = ga.granule_track_table(run, c_agg=0.5, continuation="strict")
        _, strict_tracks = granule_tracks(run, c_agg=0.5, continuation="strict")
        _, main_tracks = granule_tracks(run, c_agg=0.5)
    assert main_tracks.continuation == "main" and strict_tracks.continuation == "strict"
    pd.testing.assert_frame_equal(main_ids.drop(columns="granule_track"), strict.drop(columns="granule_track"))
    # the synthetic run has breakages and coalescences: the main branch keeps ids the strict rule renews
    assert (main_ids.granule_track != strict.granule_track).any()
    assert main_ids.granule_track.nunique() < strict.granule_track.nunique()
    lived = strict_tracks.tracks.set_index("track")
    member = strict[strict.granule >= 0]
    for track, part in member.groupby("granule_track"):
        assert part.groupby("frame").size().tolist() == list(lived.loc[track, "sizes"])
    first = member.groupby(["frame", "granule"]).granule_track.first()
    assert (granules.set_index(["frame", "granule"])["granule_track"] == first).all()
    # the commands write the same ids with --continuation strict
    out = tmp_path / "strict.csv"
    assert main(["table", run_file, "--out", str(out), "--c-agg", "0.5", "--continuation", "strict", "--quiet"]) == 0
    assert np.array_equal(pd.read_csv(out).granule_track.to_numpy(), strict.granule_track.to_numpy())
    labels = tmp_path / "labels.h5"
    assert main(["identify", run_file, "--out", str(labels), "--c-agg", "0.5", "--continuation", "strict",
                 "--quiet"]) == 0
    with h5py.File(labels, "r") as f:
        assert f.attrs["continuation"] == "strict"
        assert np.array_equal(f["granule_track"][:].ravel(), strict.granule_track.to_numpy())


def test_invalid_continuation_is_refused_before_any_work(run_file, tmp_path, capsys):
    with ga.open_run(run_file) as run, pytest.raises(ga.ParameterError,
                                                     match=r"^track_run: continuation must be one of 'main', 'strict', got str 'none'$"):
        ga.particle_table(run, c_agg=0.5, continuation="none")
    out = tmp_path / "t.csv"
    with pytest.raises(SystemExit) as refused:  # argparse refuses the option value, exit status 2
        main(["table", run_file, "--out", str(out), "--continuation", "none", "--quiet"])
    assert refused.value.code == 2 and not out.exists()
    assert "argument --continuation: invalid choice: 'none'" in capsys.readouterr().err
