"""User edge criteria (method "custom"): a small expression language evaluated by granalytics,
never by eval / pandas.eval, so a criterion string cannot run code (issue 10, item 1)."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics import ParameterError
from granalytics.cli import main
from granalytics.identification.edges import contact_table
from granalytics.identification.custom import COLUMNS, CustomEdges
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
        (f"@_kernels.os.system('{touch}') == 0", "'@'"),
        (f"@_kernels.os.system(\"{touch}\")", "'@'"),
        (f"__import__('os').system('{touch}') == 0", "calling"),
        (f"f_norm > 0.5 and __import__('os').system('{touch}') == 0", "calling"),
        ("f_norm.__class__", "attribute access"),
        (f"f_norm.__class__.__init__.__globals__['os'].system('{touch}')", "calling"),
        ("f_norm.__array__().__class__.__init__.__globals__", "attribute access"),
        ("().__class__.__bases__", "attribute access"),
        ("().__class__.__bases__[0].__subclasses__()", "calling"),
        ("f_norm[0] > 0.5", "subscripts"),
        ("f_norm[f_norm > 0.5] > 0", "subscripts"),
        ("lambda: 1", "lambda"),
        (f"(lambda: __import__('os').system('{touch}'))() == 0", "calling"),
        ("'a' == 'a'", "strings"),
        (f"open('{marker}', 'w') == 0", "calling 'open'"),
        ("f'{f_norm}' == 1", "f-strings"),
        ("os > 1", "name 'os'"),
        ("system > 1", "name 'system'"),
        ("__builtins__ > 1", "name '__builtins__'"),
        ("index > 3", "name 'index'"),
        ("(x := f_norm) > 0.5", ":="),
        ("[x for x in f_norm] == 1", "comprehensions"),
        ("sqrt(*f_norm) > 1", "starred"),
        ("maximum(f_norm, gap, out=gap) > 1", "keyword"),
        ("sqrt > 1", "must be called"),
        ("f_norm(1) > 0", "calling 'f_norm'"),
        ("True", "booleans"),
        ("1j > 0", "complex"),
        ("f_norm // 2 > 0", "'//'"),
        ("f_norm in (1, 2)", "'in'"),
        (f"f_norm > 0.5; __import__('os').system('{touch}')", "not a valid expression"),
        ("`f_norm` > 0.5", "'`'"),
        ("f_norm >", "not a valid expression"),
        ("f_norm > " + " + ".join(["f_norm"] * 200), "characters long"),
        ("-" * 200 + "f_norm > 0", "nested deeper"),
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


def test_columns_are_those_of_the_contact_table(table):
    assert tuple(table.columns) == COLUMNS


def _doc_examples():
    return [
        "f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)",
        "f_norm >= 0.5 and angle_v_deg < 30",
        "f_norm > 0.5 & angle_v_deg < 30 | angle_w_deg < 10",
        "(f_norm > 0.5) & ~(angle_v_deg >= 30)",
        "not f_norm > 0.5 or gap * 1e6 < 20",
        "0.2 < f_norm <= 0.8",
        "sqrt(f_norm) > 0.5 and abs(f_norm - 0.5) < 0.4",
        "log(f_norm) > -1 and exp(f_norm) < 3 or log10(bridge_volume) > -12",
        "f_cap / -f_normal > 0.9",
        "i % 2 == 0 and j != 3 and id_i / 2 > 100",
        "f_norm ** 2 > 0.3 and -f_norm < -0.5 and +f_norm != 1",
        "bridge_volume > 0",
    ]


@pytest.mark.parametrize("criterion", _doc_examples())
def test_valid_criteria_give_the_masks_pandas_eval_gave(criterion, table, snapshot):
    keep = ga.identify(snapshot, method="custom", criterion=criterion).kept
    with np.errstate(all="ignore"):
        expected = np.asarray(table.eval(criterion))
    assert keep.dtype == np.bool_ and keep.shape == (snapshot.n_contacts,)
    np.testing.assert_array_equal(keep, expected)


def test_valid_criteria_match_numpy(table, snapshot):
    c = {name: table[name].to_numpy() for name in COLUMNS}
    with np.errstate(all="ignore"):
        cases = {
            "f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)":
                (c["f_norm"] >= 0.5) & ((c["angle_v_deg"] < 30) | (c["angle_w_deg"] < 30)),
            "0.2 < f_norm < 0.8": (0.2 < c["f_norm"]) & (c["f_norm"] < 0.8),
            "minimum(angle_v_deg, angle_w_deg) < 30 and maximum(f_norm, 0.1) > 0.4":
                (np.minimum(c["angle_v_deg"], c["angle_w_deg"]) < 30) & (np.maximum(c["f_norm"], 0.1) > 0.4),
            "not (f_cap / f_normal < -0.5)": ~(c["f_cap"] / c["f_normal"] < -0.5),
            "~(gap > 1e-5) | bridge_volume ** 0.5 > 1e-6": ~(c["gap"] > 1e-5) | (c["bridge_volume"] ** 0.5 > 1e-6),
            "f_norm > 0.5 & angle_v_deg < 30": (c["f_norm"] > 0.5) & (c["angle_v_deg"] < 30),
            "i % 3 == 1 or j - i > 5": (c["i"] % 3 == 1) | (c["j"] - c["i"] > 5),
        }
    for criterion, expected in cases.items():
        keep = ga.identify(snapshot, method="custom", criterion=criterion).kept
        assert expected.any() and not expected.all(), criterion
        np.testing.assert_array_equal(keep, expected, err_msg=criterion)


def test_the_documented_criterion_reproduces_gna(snapshot):
    gna = ga.identify(snapshot, c_agg=0.5, a_agg_deg=30)
    custom = ga.identify(snapshot, method="custom", criterion="f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)")
    assert custom.partition() == gna.partition() and gna.n_granules > 0


def test_scalar_results_broadcast_and_non_booleans_are_refused(snapshot):
    assert ga.identify(snapshot, method="custom", criterion="1 > 0").kept.all()
    assert not ga.identify(snapshot, method="custom", criterion="2 < 1").kept.any()
    for criterion, word in [("f_norm", "float64 values, not true/false"), ("1", "int64 values, not true/false"),
                            ("f_norm + 1", "not true/false"), ("f_norm and gap > 0", "'and' needs true/false"),
                            ("~f_norm", "'~' needs a true/false")]:
        with pytest.raises(ParameterError, match="edge criterion") as exc:
            ga.identify(snapshot, method="custom", criterion=criterion)
        assert word in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(ParameterError, match="expression string or a callable"):
        CustomEdges(0.5)
    # numbers are real numbers: an integer power with a negative exponent no longer fails (int64 did)
    assert ga.identify(snapshot, method="custom", criterion="j ** -1 > 0").kept.all()


def test_callable_criteria_still_get_the_table(snapshot):
    seen = []

    def wet(t):
        seen.append(t)
        return (t.bridge_volume > 0).to_numpy()

    result = ga.identify(snapshot, method="custom", criterion=wet)
    assert isinstance(seen[0], pd.DataFrame) and result.params["criterion"] == "wet"
    np.testing.assert_array_equal(result.kept, seen[0].bridge_volume.to_numpy() > 0)
    with pytest.raises(ParameterError, match="one boolean per contact"):
        ga.identify(snapshot, method="custom", criterion=lambda t: np.ones(3, bool))


def test_cli_refuses_an_injection_with_one_line_and_exit_2(run_file, tmp_path):
    marker = tmp_path / "marker"
    criterion = f"@_kernels.os.system('touch {marker}') == 0"
    proc = subprocess.run([sys.executable, "-m", "granalytics", "compare-methods", run_file, "--methods", "gna,custom",
                           "--set", f"custom.criterion={criterion}", "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0].startswith("granalytics: error: edge criterion") and "'@' is not allowed" in lines[0]
    assert not marker.exists()


def test_cli_injections_in_process(run_file, tmp_path, capsys):
    marker = tmp_path / "marker"
    for criterion in [f"__import__('os').system('touch {marker}') == 0", "f_norm.__class__", "os > 1"]:
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


@pytest.mark.parametrize("criterion, expected", [
    ("f_norm > 2**64", "none"), ("f_norm < 10**19", "all"), ("f_norm < 2**63 * 4", "all"),
    ("f_norm > -(2**70)", "all"), ("f_norm > 9223372036854775807 + 1", "none"),
])
def test_big_integer_literals_are_real_numbers_not_wrapped_int64(snapshot, table, criterion, expected):
    """int64 arithmetic wrapped 2**64 to 0 (kept 32 of 155 contacts) and made 10**19 negative (kept none)."""
    from granalytics.identification.custom import compile_criterion, evaluate_criterion

    mask = evaluate_criterion(compile_criterion(criterion), table, snapshot.n_contacts, criterion)
    assert mask.all() if expected == "all" else not mask.any()


@pytest.mark.parametrize("criterion, exact, as_float", [
    ("id_i ** 3 % 10 < 5", lambda i, j: i**3 % 10 < 5, lambda i, j: i**3 % 10 < 5),
    ("id_i * id_j % 97 < 50", lambda i, j: i * j % 97 < 50, lambda i, j: i * j % 97 < 50),
    ("-(id_j ** 2) % 7 < 3", lambda i, j: -(j**2) % 7 < 3, lambda i, j: -(j**2) % 7 < 3),
])
def test_integer_arithmetic_is_exact(table, criterion, exact, as_float):
    """``**`` on integers went through float64 (or wrapped in int64): up to 334 of 494 contacts
    differed from exact arithmetic. Ids above 2**50 make every product exceed 2**53."""
    from granalytics.identification.custom import compile_criterion, evaluate_criterion

    big = table.assign(id_i=table["id_i"] + 2**50 + 12345, id_j=table["id_j"] + 2**50 + 98765)
    pairs = list(zip(big["id_i"].tolist(), big["id_j"].tolist()))
    expected = np.array([exact(i, j) for i, j in pairs])
    rounded = np.array([as_float(float(i), float(j)) for i, j in pairs])
    assert 0 < expected.sum() < len(expected) and (rounded != expected).any()  # float64 would be wrong here
    mask = evaluate_criterion(compile_criterion(criterion), big, len(big), criterion)
    np.testing.assert_array_equal(mask, expected)


def test_integer_powers_beyond_4096_bits_are_refused_not_computed(table):
    from granalytics.identification.custom import compile_criterion, evaluate_criterion

    for criterion in ("id_i ** 100000 > 0", "2 ** 5000 > f_norm"):
        with pytest.raises(ParameterError, match="4096 bits") as exc:
            evaluate_criterion(compile_criterion(criterion), table, len(table), criterion)
        assert "\n" not in str(exc.value)
