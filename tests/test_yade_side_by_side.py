"""The simulator beside YADE on the same drum (docs/results.md, "The simulator beside YADE"): the
kept pairs of runs (benchmarks/yade_runs/, made by benchmarks/yade_series.py; YADE is never run
here) still give the documented numbers under today's analyses."""

import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KEEP = os.path.join(ROOT, "benchmarks", "yade_runs")

#: (γ [N/m], seed, code) -> the window [1, 3] means of docs/results.md's table, as printed there
DOCUMENTED = {
    (0.03, 0, "sim"): {"yield_fraction_acting": 0.2977, "mean_volume_norm_acting": 2.698,
                       "yield_fraction_bridge": 0.726, "mean_volume_norm_bridge": 11.02,
                       "separated_share": 0.3524, "coordination": 2.907},
    (0.03, 0, "yade"): {"yield_fraction_acting": 0.2989, "mean_volume_norm_acting": 2.784,
                        "yield_fraction_bridge": 0.7471, "mean_volume_norm_bridge": 11.84,
                        "separated_share": 0.3352, "coordination": 2.852},
    (0.1095, 0, "sim"): {"yield_fraction_acting": 0.2821, "mean_volume_norm_acting": 2.684,
                         "yield_fraction_bridge": 0.822, "mean_volume_norm_bridge": 13.17,
                         "separated_share": 0.2186, "coordination": 3.727},
    (0.1095, 0, "yade"): {"yield_fraction_acting": 0.3029, "mean_volume_norm_acting": 2.813,
                          "yield_fraction_bridge": 0.8847, "mean_volume_norm_bridge": 25.89,
                          "separated_share": 0.1951, "coordination": 3.539},
    (0.444, 0, "sim"): {"yield_fraction_acting": 0.3581, "mean_volume_norm_acting": 3.182,
                        "yield_fraction_bridge": 0.9136, "mean_volume_norm_bridge": 67.39,
                        "separated_share": 0.1432, "coordination": 4.846},
    (0.444, 0, "yade"): {"yield_fraction_acting": 0.3124, "mean_volume_norm_acting": 3.08,
                         "yield_fraction_bridge": 0.9372, "mean_volume_norm_bridge": 43.02,
                         "separated_share": 0.1267, "coordination": 4.389},
}


def _side_by_side():
    spec = importlib.util.spec_from_file_location("yade_side_by_side",
                                                  os.path.join(ROOT, "benchmarks", "yade_side_by_side.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("case", sorted(DOCUMENTED))
def test_the_kept_runs_give_the_documented_numbers(case):
    import granalytics as ga

    gamma, seed, code = case
    tag = f"g{gamma:g}-s{seed}"
    side = _side_by_side()
    with ga.open_run(os.path.join(KEEP, f"sim-{tag}.h5")) as run:
        drum = run.meta
    series = side.time_series(os.path.join(KEEP, f"{code}-{tag}.h5"), (1.0, 3.0), drum,
                              {"c_agg": 0.6, "a_agg_deg": 20.0})
    means = ga.steady_state(series, window=(1.0, 3.0), columns=list(DOCUMENTED[case]))["mean"]
    for metric, value in DOCUMENTED[case].items():
        assert means[metric] == pytest.approx(value, rel=6e-4), metric  # printed to 4 digits
