"""User edge criteria (method "custom"): a Python callable on the contact table, or a string of
column-number comparisons joined by and/or/not, parsed against a whitelist and evaluated by
granalytics, never by eval / pandas.eval, so a criterion string cannot run code."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics import ParameterError
from granalytics.cli import main
from granalytics.identification.edges import contact_table
from granalytics.identification.custom import COLUMNS, CustomEdges, compile_criterion
from granalytics.datasets.synthetic import synthetic_snapshot, write_synthetic_run


@pytest.fixture(scope="module")
def snapshot():
    return synthetic_snapshot(1500, seed=12)


@pytest.fixture(scope="module")
def table(snapshot):
    return contact_table(snapshot)


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("custom") / "run.h5"
    return write_synthetic_run(path, n_particles=300, revolutions=1.0, frames_per_revolution=2, seed=4)


def injections(marker):
    """(criterion, word the one-line message must contain); each would create ``marker`` if run."""
    touch = f"touch {marker}"
    return [
        (f"@_kernels.os.system('{touch}') == 0", "not a valid expression"),
        (f"@_kernels.os.system(\"{touch}\")", "not a valid expression"),
        (f"__import__('os').system('{touch}') == 0", "function calls"),
        (f"f_norm > 0.5 and __import__('os').system('{touch}') == 0", "function calls"),
        ("f_norm.__class__", "attribute access"),
        ("f_norm.__class__ > 0", "attribute access"),
        (f"f_norm.__class__.__init__.__globals__['os'].system('{touch}')", "function calls"),
        ("f_norm.__array__().__class__.__init__.__globals__", "attribute access"),
        ("().__class__.__bases__", "attribute access"),
        ("().__class__.__bases__[0].__subclasses__()", "function calls"),
        ("f_norm[0] > 0.5", "subscripts"),
        ("f_norm[f_norm > 0.5] > 0", "subscripts"),
        ("lambda: 1", "lambda"),
        ("(lambda: 1) < f_norm", "lambda"),
        (f"(lambda: __import__('os').system('{touch}'))() == 0", "function calls"),
        ("'a' == 'a'", "strings"),
        (f"open('{marker}', 'w') == 0", "function calls"),
        ("f'{f_norm}' == 1", "f-strings"),
        ("os > 1", "name 'os'"),
        ("system > 1", "name 'system'"),
        ("__builtins__ > 1", "name '__builtins__'"),
        ("__import__ > 1", "name '__import__'"),
        ("index > 3", "name 'index'"),
        ("(x := f_norm) > 0.5", ":="),
        ("[x for x in f_norm] == 1", "comprehensions"),
        ("sqrt(*f_norm) > 1", "function calls"),
        ("maximum(f_norm, gap, out=gap) > 1", "function calls"),
        ("f_norm(1) > 0", "function calls"),
        ("True", "booleans"),
        ("f_norm == True", "booleans"),
        ("1j > f_norm", "complex"),
        ("f_norm // 2 > 0", "arithmetic"),
        ("f_norm in (1, 2)", "'in'"),
        ("f_norm is 1", "'is'"),
        (f"f_norm > 0.5; __import__('os').system('{touch}')", "not a valid expression"),
        ("`f_norm` > 0.5", "not a valid expression"),
        ("f_norm >", "not a valid expression"),
        ("f_norm > 0.5\x00", "not a valid expression"),
        ("f_norm > " + " + ".join(["f_norm"] * 200), "characters long"),
        ("not " * 200 + "f_norm > 0", "nested deeper"),
        ("(" * 300 + "f_norm > 0" + ")" * 300, "not a valid expression"),
        ("-" * 200 + "f_norm > 0", "arithmetic"),
    ]


def test_injections_are_refused_with_one_line_and_run_nothing(tmp_path, snapshot, monkeypatch):
    marker = tmp_path / "marker"
    monkeypatch.setattr(pd.DataFrame, "eval", lambda *a, **k: pytest.fail("pandas eval was called"))
    for criterion, word in injections(marker):
        with pytest.raises(ParameterError) as exc:
            ga.identify(snapshot, method="custom", criterion=criterion)
        message = str(exc.value)
        assert "\n" not in message and message.startswith("edge criterion "), message
        assert word in message, (criterion, message)
        with pytest.raises(ParameterError):
            CustomEdges(criterion)
        assert not marker.exists(), criterion


@pytest.mark.parametrize("criterion, word", [
    ("f_norm * 2 > 1", "arithmetic"), ("f_norm - 0.5 < 0.4", "arithmetic"), ("-f_norm < -0.5", "arithmetic"),
    ("sqrt(f_norm) > 0.5", "function calls"), ("abs(f_norm - 0.5) < 0.4", "function calls"),
    ("f_cap > f_coh", "comparing two columns"), ("1 < 2", "comparing two numbers"),
    ("f_norm > 0.5 & angle_v_deg < 30", "write and, or, not"), ("~(f_norm > 0.5)", "write and, or, not"),
    ("f_norm", "a bare column"), ("f_norm > 0.5 and 1", "a bare column or number"),
])
def test_arithmetic_calls_and_other_expressions_point_to_the_callable_api(snapshot, criterion, word):
    with pytest.raises(ParameterError) as exc:
        ga.identify(snapshot, method="custom", criterion=criterion)
    message = str(exc.value)
    assert "\n" not in message and word in message and "pass a callable" in message, message


def test_numbers_beyond_float64_are_refused(snapshot):
    with pytest.raises(ParameterError, match="beyond"):
        CustomEdges("f_norm < " + "9" * 400)


def test_columns_are_those_of_the_contact_table(table):
    assert tuple(table.columns) == COLUMNS


def test_valid_criteria_match_numpy(table, snapshot):
    c = {name: table[name].to_numpy() for name in COLUMNS}
    cases = {
        "f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)":
            (c["f_norm"] >= 0.5) & ((c["angle_v_deg"] < 30) | (c["angle_w_deg"] < 30)),
        "0.2 < f_norm < 0.8": (0.2 < c["f_norm"]) & (c["f_norm"] < 0.8),
        "0.8 >= f_norm > 0.2 and 30 > angle_v_deg": (c["f_norm"] <= 0.8) & (c["f_norm"] > 0.2) & (c["angle_v_deg"] < 30),
        "not (f_norm > 0.5) or gap < 2e-5": ~(c["f_norm"] > 0.5) | (c["gap"] < 2e-5),
        "not not f_norm > 0.5": c["f_norm"] > 0.5,
        "f_normal < -1e-7 and +0.5 < f_norm": (c["f_normal"] < -1e-7) & (c["f_norm"] > 0.5),
        "i != 3 and (j == 7 or id_i <= 100)": (c["i"] != 3) & ((c["j"] == 7) | (c["id_i"] <= 100)),
        "bridge_volume > 0 or f_norm >= 0.9 and angle_w_deg < 10":
            (c["bridge_volume"] > 0) | ((c["f_norm"] >= 0.9) & (c["angle_w_deg"] < 10)),
    }
    for criterion, expected in cases.items():
        keep = ga.identify(snapshot, method="custom", criterion=criterion).kept
        assert expected.any() and not expected.all(), criterion
        assert keep.dtype == np.bool_ and keep.shape == (snapshot.n_contacts,)
        np.testing.assert_array_equal(keep, expected, err_msg=criterion)


def test_integers_beyond_int64_compare_as_numbers(table):
    """No integer arithmetic: a literal beyond int64 is compared as the number it is."""
    for criterion, expected in [("id_i < 18446744073709551616", True), ("id_i > -1180591620717411303424", True),
                                ("f_norm > 18446744073709551616", False), ("id_i == 9223372036854775808", False)]:
        mask = compile_criterion(criterion)(table)
        assert mask.all() if expected else not mask.any(), criterion


def test_a_compiled_string_takes_a_dict_of_columns(table):
    columns = {name: table[name].to_numpy() for name in COLUMNS}
    np.testing.assert_array_equal(compile_criterion("0.2 < f_norm < 0.8")(columns),
                                  (columns["f_norm"] > 0.2) & (columns["f_norm"] < 0.8))


def test_the_documented_criterion_reproduces_gna(snapshot):
    gna = ga.identify(snapshot, c_agg=0.5, a_agg_deg=30)
    custom = ga.identify(snapshot, method="custom", criterion="f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)")
    assert custom.partition() == gna.partition() and gna.n_granules > 0


def test_a_criterion_that_is_neither_string_nor_callable_is_refused():
    with pytest.raises(ParameterError, match="expression string or a callable, got float"):
        CustomEdges(0.5)


def test_callable_criteria_get_the_table_and_may_do_anything(snapshot, table):
    seen = []

    def wet(t):
        seen.append(t)
        return np.sqrt(t["f_norm"].to_numpy()) * (t.bridge_volume > 0).to_numpy() > 0.5  # arithmetic, calls

    result = ga.identify(snapshot, method="custom", criterion=wet)
    assert isinstance(seen[0], pd.DataFrame) and tuple(seen[0].columns) == COLUMNS and result.params["criterion"] == "wet"
    np.testing.assert_array_equal(result.kept, np.sqrt(table.f_norm.to_numpy()) * (table.bridge_volume > 0) > 0.5)
    series = ga.identify(snapshot, method="custom", criterion=lambda t: t.f_norm >= 0.5)  # a boolean Series will do
    np.testing.assert_array_equal(series.kept, table.f_norm.to_numpy() >= 0.5)


@pytest.mark.parametrize("returns, got", [
    (lambda t: np.ones(3, bool), "shape (3,)"),
    (lambda t: t.f_norm.to_numpy(), "dtype float64"),
    (lambda t: np.ones((len(t), 1), bool), "shape"),
    (lambda t: None, "dtype object"),
])
def test_callables_giving_other_than_one_bool_per_contact_are_refused(snapshot, returns, got):
    def picky(t):
        return returns(t)

    with pytest.raises(ParameterError) as exc:
        ga.identify(snapshot, method="custom", criterion=picky)
    message = str(exc.value)
    assert "\n" not in message and "'picky'" in message and "one boolean per contact" in message and got in message


def test_a_callable_that_raises_is_named_with_its_error(snapshot):
    def broken(t):
        return t.no_such_column > 0

    with pytest.raises(ParameterError, match="'broken' failed: AttributeError") as exc:
        ga.identify(snapshot, method="custom", criterion=broken)
    assert isinstance(exc.value.__cause__, AttributeError) and "\n" not in str(exc.value)


def test_cli_refuses_an_injection_with_one_line_and_exit_2(run_file, tmp_path):
    marker = tmp_path / "marker"
    criterion = f"@_kernels.os.system('touch {marker}') == 0"
    proc = subprocess.run([sys.executable, "-m", "granalytics", "compare-methods", run_file, "--methods", "gna,custom",
                           "--set", f"custom.criterion={criterion}", "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0].startswith("granalytics: error: edge criterion") and "not a valid expression" in lines[0]
    assert not marker.exists()


def test_cli_injections_in_process(run_file, tmp_path, capsys):
    marker = tmp_path / "marker"
    for criterion in [f"__import__('os').system('touch {marker}') == 0", "f_norm.__class__", "os > 1", "f_norm * 2 > 1"]:
        argv = ["compare-methods", run_file, "--methods", "gna,custom", "--set", f"custom.criterion={criterion}", "--quiet"]
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("granalytics: error: edge criterion"), err
        assert not marker.exists()


def test_cli_accepts_a_valid_criterion(run_file, capsys):
    argv = ["compare-methods", run_file, "--methods", "gna,custom",
            "--set", "custom.criterion=f_norm >= 0.6 and (angle_v_deg < 20 or angle_w_deg < 20)", "--quiet"]
    assert main(argv) == 0
    assert "means over" in capsys.readouterr().out
