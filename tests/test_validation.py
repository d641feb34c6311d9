"""The argument validation of granalytics.base.validation: each constraint accepts and refuses, and the
decorator's one-line error names the function, the parameter and the value."""

import math
import pathlib
from numbers import Integral, Real

import numpy as np
import pandas as pd
import pytest

from granalytics.base.errors import ParameterError
from granalytics.datasets.synthetic import synthetic_snapshot
from granalytics.base.validation import (FLAG, PATH, POSITIVE, WINDOW, Array, Callable, Instance, Interval, Options,
                                         Path, validate, validate_params)
from granalytics.core.snapshot import META, SNAPSHOT


@pytest.mark.parametrize("constraint, good, bad", [
    (Interval(Real, 0, None), [0, 0.5, np.float32(2), np.int64(3), 10**300], [-1e-9, math.nan, math.inf, 10**400, "1", True,
                                                                            None]),
    (Interval(Real, 0, 180, closed="right"), [1e-9, 180, 90.0], [0, 180.0001, math.nan, False]),
    (Interval(Real, 0, 1, closed="neither"), [0.5], [0, 1, math.nan]),
    (Interval(Real, 1, 2, closed="left"), [1, 1.5], [2]),
    (Interval(Real), [-1e300, 0, 1e300], [math.inf, -math.inf, math.nan]),
    (Interval(Integral, 2, None), [2, np.int32(7), 10**30], [1, 2.0, 3.5, True, np.bool_(True), "3"]),
    (POSITIVE, [1e-300, 3], [0, -1, math.inf]),
    (Options(("acting", "bridge")), ["acting", np.str_("bridge")], ["Acting", "", None, ["acting"], 1]),
    (Options((1, 2)), [1, 2], [True, "1", 1.5]),
    (Instance(pd.DataFrame), [pd.DataFrame()], [pd.Series(dtype=float), {}, None]),
    (Instance((list, tuple)), [[], (1,)], [np.zeros(2), "ab"]),
    (FLAG, [True, False, np.bool_(True)], [1, 0, "no", None]),
    (Callable(), [len, int, lambda: 0], [None, 3, "f"]),
    (Array(), [3, [1, 2], np.zeros((2, 2)), pd.Series([1.0])], [None, "12", [1, "a"], [[1, 2], [3]], {"a": 1},
                                                               [True, False], np.array([True]), [0.5, True]]),
    (Array(ndim=1), [[1], np.arange(3), []], [3, np.zeros((2, 2))]),
    (Array(ndim=1, length=2, finite=True), [(3, 6), np.array([0.0, 1.0])], [(3,), (1, 2, 3), (0, math.nan), "3:6", 5]),
    (Array(ndim=1, within=POSITIVE), [[1, 2.5], []], [[1, 0], [1, math.nan], [1, math.inf]]),
    (Array(dtype=Integral), [[1, 2], np.arange(3, dtype=np.uint8), []], [[1.0, 2.0], [1, 2.5]]),
    (Array(ndim=1, dtype=str), [["a", "b"], ("a",), pd.Index(["a", "b"]), ()], [[1, 2], "ab", [b"a"], ["a", 1]]),
    (WINDOW, [(3, 6), (2, 2), [0.5, 1e300], np.array([-1.0, 0.0]), pd.Series([1.0, 2.0], index=[5, 7])],
     [(6, 3), (-1e308, 1e308), (0, math.inf), (0, math.nan), "3:6", (1,), (True, 2), None]),
    (PATH, ["run.h5", pathlib.Path("run.h5")], [None, b"run.h5", 5, ["run.h5"], pathlib.PurePath]),
])
def test_each_constraint_accepts_and_refuses(constraint, good, bad):
    for value in good:
        assert constraint.accepts(value), value
    for value in bad:
        assert not constraint.accepts(value), value


def test_the_snapshot_constraint_takes_a_frame_only():
    assert SNAPSHOT.accepts(synthetic_snapshot(20, seed=1))
    assert not SNAPSHOT.accepts("run.h5")
    assert "open_run" in str(SNAPSHOT)


def test_the_meta_constraint_takes_a_runs_metadata_only():
    snapshot = synthetic_snapshot(20, seed=1)
    assert META.accepts(snapshot.meta)
    assert not META.accepts(snapshot) and not META.accepts(snapshot.meta.to_dict())


@pytest.mark.parametrize("constraint, text", [
    (Interval(Real, 0, None), "a number >= 0"), (POSITIVE, "a number > 0"),
    (Interval(Real, 0, 180, closed="right"), "a number in (0, 180]"), (Interval(Real, None, 1, closed="left"), "a number < 1"),
    (Interval(Integral, 2, None), "a whole number >= 2"), (Interval(Real), "a finite number"),
    (Interval(Integral), "a whole number"), (Options(("pair", "mean")), "one of 'pair', 'mean'"),
    (Instance((list, tuple)), "a list or a tuple"), (Instance(dict, "a mapping of names"), "a mapping of names"),
    (FLAG, "True or False"), (Callable(), "a callable"),
    (Array(), "an array of numbers"), (Array(ndim=2, dtype=Integral), "a 2-D array of whole numbers"),
    (Array(ndim=1, within=POSITIVE), "a sequence of numbers > 0"), (Array(ndim=1, length=2, finite=True),
                                                                    "a pair of finite numbers"),
    (Array(ndim=1, length=3), "a sequence of 3 numbers"), (Array(ndim=1, dtype=str), "a sequence of str"),
    (PATH, "a file name (str or path-like)"), (Path("a folder"), "a folder (str or path-like)"),
])
def test_each_constraint_says_what_it_allows(constraint, text):
    assert str(constraint) == text


@validate_params({"c_agg": [Interval(Real, 0, None)], "gamma": [POSITIVE, None], "mode": [Options(("pair", "mean"))]})
def strength(snapshot, c_agg, gamma=None, *, mode="pair", **extra):
    return c_agg, gamma, mode, extra


class Method:
    @validate_params({"path": [PATH]})
    def __init__(self, path="run.h5"):
        self.path = path

    @validate_params({"window": [Array(ndim=1, length=2, finite=True)]})
    def steady(self, window=(3, 6)):
        return window


def test_the_decorator_passes_valid_arguments_through_unchanged():
    assert strength(None, 0.5) == (0.5, None, "pair", {})
    assert strength(None, c_agg=1, gamma=2.0, mode="mean", other="x") == (1, 2.0, "mean", {"other": "x"})
    assert Method().steady() == (3, 6)
    assert strength.__name__ == "strength" and "snapshot" in str(__import__("inspect").signature(strength))


@pytest.mark.parametrize("call, message", [
    (lambda: strength(None, -1), "strength: c_agg must be a number >= 0, got int -1"),
    (lambda: strength(None, math.nan), "strength: c_agg must be a number >= 0, got float nan"),
    (lambda: strength(None, True), "strength: c_agg must be a number >= 0, got bool True"),
    (lambda: strength(None, 1, "abc"), "strength: gamma must be a number > 0 or None, got str 'abc'"),
    (lambda: strength(None, 1, mode="max"), "strength: mode must be one of 'pair', 'mean', got str 'max'"),
    (lambda: Method().steady("3:6"), "Method.steady: window must be a pair of finite numbers, got str '3:6'"),
    (lambda: Method(None), "Method: path must be a file name (str or path-like), got NoneType None"),
])
def test_a_refused_argument_is_one_line_naming_function_parameter_and_value(call, message):
    with pytest.raises(ParameterError) as exc:
        call()
    assert str(exc.value) == message


def test_a_long_value_is_shown_on_one_short_line():
    with pytest.raises(ParameterError) as exc:
        Method().steady(pd.DataFrame({"a": range(100)}))
    text = str(exc.value)
    assert text.startswith("Method.steady: window must be a pair of finite numbers, got DataFrame a 0 0 1 1")
    assert "\n" not in text and text.endswith("...") and len(text) < 150


def test_a_wrong_call_gets_pythons_own_error():
    with pytest.raises(TypeError, match="missing .* 'c_agg'"):
        strength(None)
    with pytest.raises(TypeError, match="unexpected keyword"):
        Method().steady(windows=(1, 2))


@validate_params({"c_agg": [POSITIVE], "gamma": [POSITIVE, None], "mode": [Options(("pair", "mean"))]})
def _plain(snapshot, c_agg, gamma=None, *, mode="pair"):
    return c_agg, gamma, mode


def test_arguments_are_read_alike_by_position_by_keyword_and_from_defaults():
    """A signature without ``*args``/``**kwargs`` is read without ``inspect.Signature.bind``."""
    assert _plain(None, 1.0) == (1.0, None, "pair")
    assert _plain(None, c_agg=2.0, gamma=3.0, mode="mean") == (2.0, 3.0, "mean")
    for call in (lambda: _plain(None, -1.0), lambda: _plain(None, c_agg=-1.0), lambda: _plain(None, 1.0, -2.0),
                 lambda: _plain(None, 1.0, gamma=-2.0), lambda: _plain(None, 1.0, mode="x")):
        with pytest.raises(ParameterError, match=r"^_plain: (c_agg|gamma|mode) must be"):
            call()
    # a wrong call is Python's own error, even with a refused value in it
    for call, words in ((lambda: _plain(None), "missing"), (lambda: _plain(None, -1.0, c_agg=1.0), "multiple values"),
                        (lambda: _plain(None, -1.0, 1.0, "mean"), "positional"),
                        (lambda: _plain(None, -1.0, mood="x"), "unexpected")):
        with pytest.raises(TypeError, match=words):
            call()


def test_a_constraint_on_a_parameter_the_function_lacks_is_a_programming_error():
    def f(c_agg):
        return c_agg

    with pytest.raises(TypeError, match="f has no parameter c_ag"):
        validate_params({"c_ag": [POSITIVE]})(f)


def test_validate_checks_a_mapping_of_values_with_or_without_a_name():
    validate("GNA", {"c_agg": [POSITIVE]}, {"c_agg": 1.0})
    with pytest.raises(ParameterError, match=r"^GNA: c_agg must be a number > 0, got int 0$"):
        validate("GNA", {"c_agg": [POSITIVE]}, {"c_agg": 0})
    with pytest.raises(ParameterError, match=r"^c_agg must be"):
        validate(None, {"c_agg": [POSITIVE]}, {"c_agg": 0})


def test_a_warning_points_at_the_users_call_through_every_decorated_layer(tmp_path):
    """Warnings name the first caller outside granalytics, not the decorator's wrapper."""
    import inspect
    import warnings

    import granalytics as ga
    from granalytics.datasets.synthetic import write_synthetic_run

    with ga.open_run(write_synthetic_run(tmp_path / "r.h5", 200, revolutions=1.0, frames_per_revolution=8)) as run:
        ts = ga.run_stats(run)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        line = inspect.currentframe().f_lineno + 1
        ga.steady_state(ts, window=(0, 1e9))  # past the run's end: clipped, with a warning
    assert caught and all((w.filename, w.lineno) == (__file__, line) for w in caught), \
        [(w.filename, w.lineno, str(w.message)[:40]) for w in caught]
