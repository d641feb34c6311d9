import math

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics import ParameterError, RunWriter, open_run
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
from conftest import R0, expects_small_run_warnings, make_meta, make_snapshot


@pytest.fixture
def three_granules():
    # granule A: particles 0,1 (equal spheres 2R0 apart), granule B: 2,3,4 in a line; 5, 6 free
    radius = np.array([R0, R0, R0, R0, 2 * R0, R0, R0])
    position = np.array([[0, 0, 0], [2 * R0, 0, 0], [0, 1, 0], [0, 1 + 2 * R0, 0], [0, 1 + 5 * R0, 0], [5, 5, 5], [6, 6, 6]], float)
    film = np.array([1, 2, 3, 4, 5, 6, 7], float) * 1e-12
    pairs = [(0, 1), (2, 3), (3, 4), (4, 5)]
    bridge = np.array([10, 20, 30, 40], float) * 1e-12
    f_norm = [1.0, 1.0, 1.0, 0.1]  # (4,5) too weak: 5 stays free, but its bridge exists
    return make_snapshot(7, pairs, f_norm, radius=radius, position=position, film_volume=film, bridge_volume=bridge,
                         meta=make_meta(10), time=math.pi, step=7)


def test_granule_table_values(three_granules):
    s = three_granules
    r = ga.identify(s)
    t = r.granules
    assert list(t.index) == [0, 1] and t.index.name == "granule"
    v = 4 / 3 * math.pi * R0**3
    b, a = t.loc[0], t.loc[1]  # B (3 particles) is granule 0
    assert b.n_particles == 3 and a.n_particles == 2
    assert a.volume_m3 == pytest.approx(2 * v) and b.volume_m3 == pytest.approx(10 * v)
    assert (a.com_x_m, a.com_y_m, a.com_z_m) == pytest.approx((R0, 0, 0))
    assert a.radius_of_gyration_m == pytest.approx(R0)  # two equal point masses 2R0 apart
    y = np.array([1, 1 + 2 * R0, 1 + 5 * R0])
    w = np.array([1, 1, 8.0])
    com = (w * y).sum() / w.sum()
    assert b.com_y_m == pytest.approx(com)
    assert b.radius_of_gyration_m == pytest.approx(math.sqrt((w * (y - com) ** 2).sum() / w.sum()))
    assert a.film_volume_m3 == pytest.approx(3e-12) and b.film_volume_m3 == pytest.approx(12e-12)
    assert a.bridge_volume_m3 == pytest.approx(10e-12) and b.bridge_volume_m3 == pytest.approx(50e-12)  # (4,5) excluded
    assert b.liquid_volume_m3 == pytest.approx(62e-12)
    assert b.liquid_solid_ratio == pytest.approx(62e-12 / (10 * v))


def test_granule_table_of_a_frame_without_granules_is_empty():
    s = make_snapshot(3, [(0, 1)], [0.1])
    t = ga.identify(s).granules
    assert len(t) == 0 and "volume_m3" in t.columns


def test_frame_stats_normalisations(three_granules):
    s = three_granules
    row = ga.frame_stats(s, ga.identify(s)).iloc[0]
    v = s.particle_volume
    assert row.n_granules == 2 and row.n_granules_norm == pytest.approx(2 / 10)  # meta.n_particles = 10
    assert row.yield_fraction == pytest.approx(5 / 7)
    assert row.mean_volume_m3 == pytest.approx(12 * v[0] / 2)
    assert row.mean_volume_norm == pytest.approx(6 * v[0] / v.mean())
    assert row.mean_granule_size == 2.5 and row.largest_granule_size == 3
    assert row.revolutions == pytest.approx(1.0)  # t = π s at Ω = 2 rad/s
    assert row.n_kept_contacts == 3 and row.n_contacts == 4


def test_frame_stats_without_granules_gives_nan_mean_volume():
    s = make_snapshot(3, [(0, 1)], [0.1])
    row = ga.frame_stats(s, ga.identify(s)).iloc[0]
    assert row.n_granules == 0 and row.yield_fraction == 0 and math.isnan(row.mean_volume_norm)


def test_mean_volume_norm_is_cg_invariant_for_planted_granules():
    # identical lattice structure at α = 1 and α = 2: normalised metrics agree exactly
    a = synthetic_snapshot(2000, seed=4, alpha=1.0)
    b = synthetic_snapshot(2000, seed=4, alpha=2.0)
    ra, rb = ga.frame_stats(a, ga.identify(a)), ga.frame_stats(b, ga.identify(b))
    for col in ("n_granules_norm", "mean_volume_norm", "yield_fraction"):
        assert ra[col].iloc[0] == pytest.approx(rb[col].iloc[0], rel=1e-12)
    assert rb.mean_volume_m3.iloc[0] == pytest.approx(8 * ra.mean_volume_m3.iloc[0])


def test_run_stats_time_series_matches_frame_by_frame(tmp_path):
    meta = synthetic_meta(500)
    frames = [synthetic_snapshot(500, time=0.3 * k, granulated_fraction=0.1 * k, seed=k, meta=meta) for k in range(4)]
    with RunWriter(tmp_path / "r.h5", meta) as w:
        for f in frames:
            w.append(f)
    with open_run(tmp_path / "r.h5") as run:
        ts, sizes = ga.run_stats(run, c_agg=0.5, return_sizes=True)
        sub = ga.run_stats(run[2:], c_agg=0.5)
    assert list(ts.frame) == [0, 1, 2, 3]
    assert ts.revolutions.to_numpy() == pytest.approx(0.3 * np.arange(4) * 2 / (2 * math.pi))
    for k, f in enumerate(frames):
        r = ga.identify(f, c_agg=0.5)
        expected = ga.frame_stats(f, r).iloc[0]
        assert ts.yield_fraction[k] == expected.yield_fraction
        assert np.array_equal(sizes[k], r.sizes)
    assert ts.yield_fraction.is_monotonic_increasing
    pd.testing.assert_frame_equal(sub.drop(columns="frame"), ts.iloc[2:].drop(columns="frame").reset_index(drop=True))
    with pytest.raises(ParameterError, match="no frames"):
        ga.run_stats([])


def test_steady_state_window_mean_std_and_block_sem():
    revs = np.arange(0, 7.01, 0.25)
    value = np.where(revs < 3, 0.0, 1.0 + np.floor(revs - 3) * 0.1)  # block means 1.0, 1.1, 1.2 (+1.2 at 6.0)
    ts = pd.DataFrame({"revolutions": revs, "yield_fraction": value})
    out = ga.steady_state(ts, window=(3, 6), columns=["yield_fraction"], n_blocks=3)  # fixed blocks
    inside = value[(revs >= 3) & (revs <= 6)]
    row = out.loc["yield_fraction"]
    assert row["mean"] == pytest.approx(inside.mean()) and row["std"] == pytest.approx(inside.std(ddof=1))
    assert row.n_frames == 13 and row.n_blocks == 3  # 6.0 joins the [5, 6) block
    blocks = np.array([1.0, 1.1, (4 * 1.2 + 1.3) / 5])
    assert row["sem"] == pytest.approx(blocks.std(ddof=1) / math.sqrt(3))
    with pytest.raises(ParameterError, match="no frame in the window"):
        ga.steady_state(ts, window=(8, 9), columns=["yield_fraction"])
    with pytest.raises(ParameterError, match=r"steady_state: window must be a pair of finite numbers \(lo, hi\) with lo <= hi, got tuple \(5, 4\)"):
        ga.steady_state(ts, window=(5, 4), columns=["yield_fraction"])
    with pytest.raises(ParameterError, match="steady_state: columns must name at least one metric"):
        ga.steady_state(ts, window=(3, 6), columns=[])


def test_steady_state_skips_nan_frames_and_counts_them():
    ts = pd.DataFrame({"revolutions": [3.0, 3.5, 4.0, 4.5], "mean_volume_norm": [2.0, np.nan, 4.0, 6.0]})
    row = ga.steady_state(ts, window=(3, 4.5), columns=["mean_volume_norm"]).loc["mean_volume_norm"]
    assert row["mean"] == 4.0 and row.n_frames == 3


def test_frames_a_rounding_away_from_a_window_edge_are_inside_it():
    # a frame every 0.05 revolution rounded to whole steps: stamped slightly early, as in a run of
    # another time step; the same window must take the same frames and blocks as on the exact grid
    exact = np.round(np.arange(0, 121) * 0.05, 10)
    early = exact * (1 - 2e-5)  # revolution 6 stamped 5.99988
    for revs in (exact, early):
        ts = pd.DataFrame({"revolutions": revs, "yield_fraction": np.floor(exact)})  # value = its revolution
        row = ga.steady_state(ts, window=(3, 6), columns=["yield_fraction"], n_blocks=3).loc["yield_fraction"]
        assert row.n_frames == 61 and row.n_blocks == 3
        # block means 3, 4 and (20 × 5 + 6)/21: the frame of revolution 4 opens the second block
        blocks = np.array([3.0, 4.0, (20 * 5 + 6) / 21])
        assert row["sem"] == pytest.approx(blocks.std(ddof=1) / math.sqrt(3))
    # a frame a fifth of the spacing outside is outside
    ts = pd.DataFrame({"revolutions": exact + 0.01, "yield_fraction": 1.0})
    assert ga.steady_state(ts, window=(3, 6), columns=["yield_fraction"]).loc["yield_fraction"].n_frames == 60


def test_a_window_the_run_does_not_cover_warns_naming_the_run():
    ts = pd.DataFrame({"revolutions": np.arange(0, 61) * 0.05, "yield_fraction": 0.5})  # 3 revolutions
    with pytest.warns(UserWarning, match=r"cg1\.h5: the window \[3, 6\] revolutions runs past the run's end.*"
                                         r"clipped to \[3, 3\], 1 frame$"):
        ga.steady_state(ts, columns=["yield_fraction"], source="cg1.h5")
    with pytest.raises(ParameterError, match=r"^cg1\.h5: no frame in the window \[4, 5\]"):
        ga.steady_state(ts, window=(4, 5), columns=["yield_fraction"], source="cg1.h5")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ga.steady_state(ts, window=(1, 3), columns=["yield_fraction"])  # covered: no warning


@pytest.mark.parametrize("n_blocks", [None, 5])
def test_a_window_past_the_runs_end_is_clipped_to_its_frames(n_blocks):
    """--window 3:9 on a run ending at 6 took the frames of 3:6 but blocks of 3:9 (another s.e.m.):
    the blocks now span the frames used, with one warning saying so."""
    rng = np.random.default_rng(3)
    revs = np.arange(0, 121) * 0.05 * (1 - 2e-5)  # revolution 6 stamped 5.99988
    ts = pd.DataFrame({"revolutions": revs, "yield_fraction": 0.3 + 0.05 * rng.standard_normal(revs.size)})
    exact = ga.steady_state(ts, window=(3, 6), columns=["yield_fraction"], n_blocks=n_blocks)
    for window in ((3, 9), (3, 6.5), (3, 100)):
        with pytest.warns(UserWarning, match=r"run\.h5: the window \[3, [0-9.]+\] revolutions runs past the run's "
                                             r"end \(the run covers \[0, 6\]\): clipped to \[3, 6\], 61 frames$") as record:
            wide = ga.steady_state(ts, window=window, columns=["yield_fraction"], n_blocks=n_blocks, source="run.h5")
        assert len(record) == 1
        pd.testing.assert_frame_equal(wide, exact)
    late = pd.DataFrame({"revolutions": revs + 1, "yield_fraction": ts["yield_fraction"]})  # from 1 to 7
    with pytest.warns(UserWarning, match=r"starts before the run.*clipped to \[1, 4\]"):
        early = ga.steady_state(late, window=(0, 4), columns=["yield_fraction"], n_blocks=n_blocks)
    pd.testing.assert_frame_equal(early, ga.steady_state(late, window=(1, 4), columns=["yield_fraction"],
                                                         n_blocks=n_blocks))


def test_the_stats_command_clips_a_window_past_the_runs_end(capsys):
    from pathlib import Path

    from granalytics.cli import main

    run = str(Path(__file__).parents[1] / "datasets" / "lab-cg3.h5")
    tables = {}
    for window in ("3:9", "3:6"):
        assert main(["stats", run, "--window", window, "--window-rev", "2.9:6.1", "--quiet"]) == 0
        printed = capsys.readouterr()
        out = printed.out.splitlines()
        tables[window] = out[1:7]
        assert ("clipped to the run's frames" in out[0]) == (window == "3:9")
        assert printed.err.count("clipped to [3, 6]") == (window == "3:9")
    assert tables["3:9"] == tables["3:6"] and "block_sem" in tables["3:6"][0]


def test_size_distribution_log_bins():
    sizes = [np.array([2, 2, 3, 10]), np.array([2, 150])]
    d = ga.size_distribution(sizes, bins_per_decade=5)
    assert d["count"].sum() == 6
    assert (d.size_min.to_numpy()[1:] == d.size_max.to_numpy()[:-1] + 1).all()  # contiguous integer bins
    assert d.size_min.iloc[0] == 2 and d.size_max.iloc[-1] >= 150
    widths = d.size_max - d.size_min + 1
    assert (d.density * widths).sum() == pytest.approx(1.0)
    first = d.iloc[0]
    assert first["count"] == (np.concatenate(sizes) <= first.size_max).sum()
    ratios = (d.size_max + 1) / d.size_min
    assert ratios.max() < 10 ** (1 / 5) * 1.5  # about five bins per decade
    with pytest.raises(ParameterError):
        ga.size_distribution([np.array([1, 2])])


@expects_small_run_warnings
def test_a_window_tolerance_never_takes_in_a_neighbouring_frame():
    # a run thinned to one frame in 20 outside a dense window: the tolerance follows the dense
    # spacing, so the window [6.0, 6.05] takes its two frames and not 5.95 or 6.1
    revs = np.concatenate([np.arange(0, 5.9, 1.0), np.round(np.arange(5.9, 6.2001, 0.05), 10), [7.0, 8.0]])
    ts = pd.DataFrame({"revolutions": revs, "yield_fraction": revs})
    row = ga.steady_state(ts, window=(6.0, 6.05), columns=["yield_fraction"]).loc["yield_fraction"]
    assert row.n_frames == 2 and row["mean"] == pytest.approx(6.025)
    with pytest.warns(UserWarning, match="holds a single frame"):
        ga.steady_state(ts, window=(6.01, 6.06), columns=["yield_fraction"])
    with pytest.raises(ParameterError, match="no frames with a finite time_s"):
        ga.steady_state(pd.DataFrame({"time_s": [np.nan, np.nan], "yield_fraction": [1.0, 2.0]}), window=(0, 1),
                        by="time_s", columns=["yield_fraction"])


def test_blocking_sem_covers_correlated_frames():
    """Frames correlated over many frames (an AR(1) series, as a granule population that changes
    over a fraction of a revolution): short blocks give far too small an error; the blocking
    (largest error over the merging levels) gives most of the true spread of the mean."""
    from granalytics.analysis.stats import blocking_sem

    rng = np.random.default_rng(0)
    n, phi, runs = 240, 0.9, 300
    means, blocked, naive = [], [], []
    for _ in range(runs):
        x = np.empty(n)
        x[0] = rng.normal()
        for k in range(1, n):
            x[k] = phi * x[k - 1] + rng.normal()
        means.append(x.mean())
        sums, counts = x.reshape(48, 5).sum(axis=1), np.full(48, 5)
        blocked.append(blocking_sem(sums, counts)[0])
        naive.append((sums / counts).std(ddof=1) / math.sqrt(48))
    true = np.std(means)
    assert 0.7 < np.median(blocked) / true < 1.3
    assert np.median(naive) / true < 0.6  # what fixed short blocks would report
    # independent frames: about the plain standard error
    ratios = []
    for _ in range(runs):
        x = rng.normal(size=240)
        ratios.append(blocking_sem(x.reshape(48, 5).sum(axis=1), np.full(48, 5))[0] / (1 / math.sqrt(240)))
    assert 0.9 < np.median(ratios) < 1.3


def test_replica_steady_state_reports_the_run_to_run_error():
    """Replicas whose levels differ by more than their frames scatter: the replica error shows it,
    the block error of each run does not."""
    rng = np.random.default_rng(5)
    revs = np.round(np.arange(0, 121) * 0.05, 10)
    levels = [0.40, 0.48, 0.44, 0.52]
    series = [pd.DataFrame({"revolutions": revs, "yield_fraction": level + rng.normal(0, 0.005, revs.size)})
              for level in levels]
    out = ga.replica_steady_state(series, window=(3, 6), columns=["yield_fraction"]).loc["yield_fraction"]
    assert out["mean"] == pytest.approx(np.mean(levels), abs=2e-3)
    assert out["replica_sem"] == pytest.approx(np.std(levels, ddof=1) / 2, rel=0.1)
    assert out["block_sem"] < out["replica_sem"] / 5 and out["n_replicas"] == 4
    with pytest.raises(ParameterError, match="at least two replicas"):
        ga.replica_steady_state(series[:1])


def test_a_window_whose_statistics_still_drift_is_said_not_to_be_a_steady_state():
    """Round four, C13: stats --window 1:2 on a run whose yield still rose reported a steady state."""
    import warnings

    revs = np.arange(0, 2.0001, 0.05)
    rng = np.random.default_rng(0)
    rising = pd.DataFrame({"revolutions": revs, "time_s": revs * 3.14,
                           "yield_fraction": 0.1 + 0.2 * revs + rng.normal(0, 0.01, revs.size),
                           "n_granules_norm": 0.1 + rng.normal(0, 0.005, revs.size),
                           "mean_volume_norm": 3 + rng.normal(0, 0.05, revs.size)})
    with pytest.warns(UserWarning, match=r"run.h5: the window \[0, 2\] revolutions is not a steady state: "
                                         r"yield_fraction changes by \+0.4"):
        ga.steady_state(rising, window=(0, 2), columns=("yield_fraction", "n_granules_norm", "mean_volume_norm"),
                        source="run.h5")
    steady = rising.assign(yield_fraction=0.5 + rng.normal(0, 0.01, revs.size))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ga.steady_state(steady, window=(0, 2), columns=("yield_fraction", "n_granules_norm", "mean_volume_norm"))
