"""The simulator beside YADE on the same drum (docs/results.md, "The simulator beside YADE"): the
kept pairs of runs (benchmarks/yade_runs/, made by benchmarks/yade_series.py; YADE is never run
here) still give the documented numbers under today's analyses."""

import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KEEP = os.path.join(ROOT, "benchmarks", "yade_runs")

#: the per-frame metrics whose window [1, 3] means each kept run must give (benchmarks/yade_side_by_side.py)
METRICS = ["yield_fraction_acting", "mean_volume_norm_acting", "yield_fraction_bridge", "mean_volume_norm_bridge",
           "separated_share", "coordination", "bed_angle_deg", "wall_share"]

#: kept run (relative to benchmarks/yade_runs) -> its window [1, 3] means of METRICS, to 4 digits, as printed by
#: ``python tests/test_yade_side_by_side.py``; docs/results.md's tables are the means over seeds of these
DOCUMENTED = {
    'sim-g0.03-s0.h5': (0.2977, 2.698, 0.726, 11.02, 0.3524, 2.907, 44.01, 0.2397),
    'sim-g0.03-s1.h5': (0.3071, 2.789, 0.7232, 11.87, 0.3583, 2.915, 44.07, 0.2374),
    'sim-g0.03-s2.h5': (0.3127, 2.746, 0.7383, 11.77, 0.356, 2.919, 43.54, 0.2412),
    'sim-g0.1095-s0.h5': (0.2821, 2.684, 0.822, 13.17, 0.2186, 3.727, 52.2, 0.2972),
    'sim-g0.1095-s1.h5': (0.2968, 2.798, 0.841, 17.48, 0.2102, 3.768, 52.63, 0.2972),
    'sim-g0.1095-s2.h5': (0.2995, 2.821, 0.8503, 21.08, 0.2098, 3.723, 52.89, 0.3206),
    'sim-g0.444-s0.h5': (0.3581, 3.182, 0.9136, 67.39, 0.1432, 4.846, 56.85, 0.0852),
    'sim-g0.444-s1.h5': (0.3464, 3.095, 0.9253, 44.87, 0.1401, 4.772, 57.45, 0.1233),
    'sim-g0.444-s2.h5': (0.3551, 3.092, 0.9203, 54.64, 0.1424, 4.833, 58.14, 0.0893),
    'walls/sim-drywalls-g0.03-s0.h5': (0.3212, 2.812, 0.7425, 10.78, 0.3478, 3.188, 38.85, 0.1787),
    'walls/sim-drywalls-g0.03-s1.h5': (0.3277, 2.82, 0.7402, 10.89, 0.352, 3.158, 38.88, 0.1799),
    'walls/sim-drywalls-g0.03-s2.h5': (0.3282, 2.754, 0.7333, 10.86, 0.3547, 3.166, 38.88, 0.18),
    'walls/sim-drywalls-g0.444-s0.h5': (0.3928, 3.248, 0.958, 168.2, 0.1285, 5.254, 42.29, 0.05418),
    'walls/sim-drywalls-g0.444-s1.h5': (0.3819, 3.225, 0.9381, 131.9, 0.1356, 5.254, 40.02, 0.04898),
    'walls/sim-drywalls-g0.444-s2.h5': (0.3825, 3.155, 0.9455, 158.7, 0.1319, 5.263, 42.74, 0.05171),
    'walls/sim-f96-g0.03-s0.h5': (0.3001, 2.722, 0.723, 10.75, 0.356, 2.901, 43.66, 0.2356),
    'walls/sim-f96-g0.03-s1.h5': (0.297, 2.742, 0.7148, 10.81, 0.3593, 2.885, 44.03, 0.2386),
    'walls/sim-f96-g0.03-s2.h5': (0.2993, 2.72, 0.732, 9.469, 0.3535, 2.906, 43.68, 0.2437),
    'walls/sim-f96-g0.444-s0.h5': (0.3179, 3.03, 0.8918, 41.39, 0.1402, 4.873, 54.97, 0.104),
    'walls/sim-f96-g0.444-s1.h5': (0.3543, 3.181, 0.9272, 63.43, 0.1342, 4.913, 55.25, 0.08865),
    'walls/sim-f96-g0.444-s2.h5': (0.3506, 3.136, 0.9363, 49.81, 0.1361, 4.772, 56.84, 0.1347),
    'walls/yade-drywalls-g0.03-s0.h5': (0.3273, 2.766, 0.7385, 11.52, 0.3489, 3.172, 38.77, 0.1799),
    'walls/yade-drywalls-g0.03-s1.h5': (0.33, 2.801, 0.7577, 11.71, 0.3447, 3.212, 39.04, 0.1782),
    'walls/yade-drywalls-g0.03-s1.h5': (0.33, 2.801, 0.7577, 11.71, 0.3447, 3.212, 39.04, 0.1782),
    'walls/yade-drywalls-g0.444-s0.h5': (0.382, 3.244, 0.9489, 144.1, 0.135, 5.243, 41.88, 0.05008),
    'walls/yade-drywalls-g0.444-s1.h5': (0.3942, 3.261, 0.9499, 136.2, 0.1373, 5.257, 42.36, 0.04507),
    'walls/yade-drywalls-g0.444-s2.h5': (0.3852, 3.212, 0.9575, 187.6, 0.1305, 5.267, 42.22, 0.04774),
    'walls/yade-seg384-g0.444-s0.h5': (0.405, 3.7, 0.9971, 296.8, 0.1195, 4.639, 6.527, 0.2176),
    'yade-g0.03-s0.h5': (0.2989, 2.784, 0.7471, 11.84, 0.3352, 2.852, 48.82, 0.3126),
    'yade-g0.03-s1.h5': (0.3164, 2.859, 0.7487, 12.93, 0.3494, 2.794, 48.64, 0.3195),
    'yade-g0.03-s2.h5': (0.3057, 2.751, 0.7332, 13.34, 0.3446, 2.824, 48.89, 0.3134),
    'yade-g0.1095-s0.h5': (0.3029, 2.813, 0.8847, 25.89, 0.1951, 3.539, 55.6, 0.4714),
    'yade-g0.1095-s1.h5': (0.3, 2.796, 0.8978, 25.28, 0.1881, 3.495, 55.91, 0.5495),
    'yade-g0.1095-s2.h5': (0.3094, 2.905, 0.8939, 27.02, 0.1959, 3.466, 55.52, 0.5175),
    'yade-g0.444-s0.h5': (0.3124, 3.08, 0.9372, 43.02, 0.1267, 4.389, 65.31, 0.29),
    'yade-g0.444-s1.h5': (0.3862, 3.586, 0.9943, 296.2, 0.1199, 4.612, 33.43, 0.2231),
    'yade-g0.444-s2.h5': (0.3593, 3.22, 0.9876, 273.8, 0.1078, 4.638, 41.34, 0.2277),
}


def _side_by_side():
    spec = importlib.util.spec_from_file_location("yade_side_by_side",
                                                  os.path.join(ROOT, "benchmarks", "yade_side_by_side.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _means(path, drum):
    import granalytics as ga

    series = _side_by_side().time_series(path, (1.0, 3.0), drum, {"c_agg": 0.6, "a_agg_deg": 20.0})
    return ga.steady_state(series, window=(1.0, 3.0), columns=METRICS)["mean"]


def _drum():
    import granalytics as ga

    with ga.open_run(os.path.join(KEEP, "sim-g0.03-s0.h5")) as run:
        return run.meta


@pytest.mark.parametrize("name", sorted(DOCUMENTED))
def test_the_kept_runs_give_the_documented_numbers(name):
    means = _means(os.path.join(KEEP, name), _drum())
    for metric, value in zip(METRICS, DOCUMENTED[name]):
        assert means[metric] == pytest.approx(value, rel=6e-4), metric  # printed to 4 digits


if __name__ == "__main__":  # print DOCUMENTED for every kept run (after a new run or an intentional change)
    import glob

    print("DOCUMENTED = {")
    for path in sorted(glob.glob(os.path.join(KEEP, "*.h5")) + glob.glob(os.path.join(KEEP, "walls", "*.h5"))):
        means = _means(path, _drum())
        print(f"    {os.path.relpath(path, KEEP)!r}: ({', '.join(f'{means[m]:.4g}' for m in METRICS)}),")
    print("}")
