import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics import ParameterError, RunWriter, open_run
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot

C_GRID = [0.0, 0.1, 0.35, 0.6, 0.6000001, 0.8, 1.0, 1.5]
A_GRID = [5.0, 20.0, 90.0, 180.0]


@pytest.fixture(scope="module")
def frames():
    meta = synthetic_meta(1500)
    return [synthetic_snapshot(1500, time=0.5 * k, granulated_fraction=0.2 * (k + 1), seed=30 + k, meta=meta)
            for k in range(3)]


def test_one_pass_sweep_equals_independent_identifications(frames):
    table = ga.sensitivity(frames, c_agg=C_GRID, a_agg_deg=A_GRID)
    assert len(table) == len(frames) * len(C_GRID) * len(A_GRID)
    assert {"time_s", "cohesion", "c_agg", "a_agg_deg", "yield_fraction", "n_granules_norm", "mean_volume_norm"} <= set(table.columns)
    assert sorted(set(table.time_s)) == [s.time for s in frames]
    for (frame, c, a), row in table.set_index(["frame", "c_agg", "a_agg_deg"]).iterrows():
        s = frames[frame]
        expected = ga.frame_stats(s, ga.identify(s, c_agg=c, a_agg_deg=a)).iloc[0]
        assert row.n_granules == expected.n_granules
        assert row.yield_fraction == expected.yield_fraction
        assert row.n_granules_norm == expected.n_granules_norm
        if expected.n_granules:
            assert row.mean_volume_norm == pytest.approx(expected.mean_volume_norm, rel=1e-12)
        else:
            assert np.isnan(row.mean_volume_norm)


def test_sweep_is_monotone_in_c_agg_and_parallel_equals_serial(tmp_path, frames):
    with RunWriter(tmp_path / "r.h5", frames[0].meta) as w:
        for f in frames:
            w.append(f)
    with open_run(tmp_path / "r.h5") as run:
        serial = ga.sensitivity(run, c_agg=np.linspace(0, 1, 21), a_agg_deg=[20], jobs=1)
        parallel = ga.sensitivity(run[1:], c_agg=np.linspace(0, 1, 21), a_agg_deg=[20], jobs=2)
    pd.testing.assert_frame_equal(serial[serial.frame >= 1].reset_index(drop=True), parallel)
    for _, group in serial.groupby("frame"):
        assert group.yield_fraction.is_monotonic_decreasing  # sorted by c_agg ascending


def test_summary_over_a_window(frames):
    table = ga.sensitivity(frames, c_agg=[0.6], a_agg_deg=[20])
    table["revolutions"] = [0.0, 1.0, 2.0]
    summary = ga.sensitivity_summary(table, window=(0.5, 2.5))
    assert summary.n_frames.tolist() == [2]
    assert summary.yield_fraction_mean.iloc[0] == pytest.approx(table.yield_fraction[1:].mean())
    assert summary.yield_fraction_std.iloc[0] == pytest.approx(table.yield_fraction[1:].std())
    with pytest.raises(ParameterError, match="no frame"):
        ga.sensitivity_summary(table, window=(5, 6))


@pytest.mark.parametrize("kw, words", [({"c_agg": []}, "c_agg"), ({"c_agg": [-1]}, "c_agg"),
                                       ({"a_agg_deg": [0]}, "a_agg_deg"), ({"jobs": 0}, "jobs")])
def test_bad_grids_are_rejected(frames, kw, words):
    args = {"c_agg": [0.5], "a_agg_deg": [20], **kw}
    with pytest.raises(ParameterError, match=words):
        ga.sensitivity(frames, **args)


def test_a_repeated_angle_is_swept_once():
    from granalytics.datasets.synthetic import synthetic_snapshot

    frame = synthetic_snapshot(300, seed=4)
    once = ga.sensitivity([frame], [0.5], [20.0])
    twice = ga.sensitivity([frame], [0.5], [20.0, 20.0])
    assert len(twice) == len(once) == 1
