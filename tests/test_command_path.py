"""A command reads parse -> analyse -> report: the calls a command's function makes into granalytics,
in order, enter the analysis layer once and then the report layer, which writes; before the
analysis the report layer only checks that the outputs may be written (nothing is lost after
minutes of work)."""

import sys

import pytest

from granalytics.cli import main
from granalytics.datasets import DATASET_DIR

pytestmark = [pytest.mark.filterwarnings("ignore:.*D/d = .* is below:UserWarning"),
              pytest.mark.filterwarnings("ignore:.*CG rule weber at:UserWarning")]

#: what the report layer may be asked before the analysis: loading it, checking the outputs
CHECKS = {"__getattr__", "output_paths", "check_outputs"}


def calls_of(command_function_name, argv) -> list:
    """``(module, function)`` of the granalytics functions that ``command_function_name`` calls
    directly while ``granalytics argv`` runs, in call order (a function behind ``validate_params``
    or ``functools.singledispatch`` by its own name)."""
    calls = []

    wrappers = set()  # the validate_params wrappers the command called: their callee is the call

    def profile(frame, event, arg):
        if event == "return":
            wrappers.discard(id(frame))  # a frame's id is reused once it is gone
        if event != "call" or frame.f_back is None:
            return
        caller = frame.f_back
        from_command = caller.f_code.co_name == command_function_name or id(caller) in wrappers
        if from_command and frame.f_globals.get("__name__") in ("granalytics.base.validation", "functools"):
            wrappers.add(id(frame))  # validate_params' or singledispatch's wrapper: its callee is the call
            return
        if not from_command:
            return
        module, name = frame.f_globals.get("__name__", ""), frame.f_code.co_name
        if module.startswith("granalytics.") and not name.startswith("<"):
            calls.append((module, name))

    sys.setprofile(profile)
    try:
        assert main(argv) == 0
    finally:
        sys.setprofile(None)
    return calls


def check_one_way(calls) -> None:
    """Parse (command line, core, identification), one analysis call, then the report layer."""
    layer = [module.split(".")[1] for module, _ in calls]
    analyses = [k for k, name in enumerate(layer) if name == "analysis"]
    assert len(analyses) == 1, f"the analysis is entered {len(analyses)} times: {calls}"
    before, after = calls[:analyses[0]], calls[analyses[0] + 1:]
    assert all(name in CHECKS for (module, name) in before if module.startswith("granalytics.report")), calls
    assert after and all(module.startswith("granalytics.report") for module, _ in after), calls


def test_compare_cg_is_parse_then_one_analysis_then_the_report(tmp_path):
    runs = [str(DATASET_DIR / "lab-cg2.h5"), str(DATASET_DIR / "lab-cg3.h5")]
    calls = calls_of("cmd_compare_cg", ["compare-cg", *runs, "--window", "3:4", "--out", str(tmp_path / "cg"),
                                        "--quiet"])
    check_one_way(calls)
    assert ("granalytics.analysis.cg", "compare_cg") in calls and ("granalytics.report.registry", "_save_cg") in calls


@pytest.mark.parametrize("calls", [
    [("granalytics.cli.options", "x"), ("granalytics.analysis.cg", "compare_cg"), ("granalytics.report.registry", "save"),
     ("granalytics.analysis.stats", "run_stats")],
    [("granalytics.report.registry", "save"), ("granalytics.analysis.cg", "compare_cg"),
     ("granalytics.report.tables", "format_cg_table")],
    [("granalytics.analysis.cg", "compare_cg"), ("granalytics.cli.options", "x"), ("granalytics.report.registry", "save")],
])
def test_the_check_sees_a_command_that_goes_back_or_writes_first(calls):
    with pytest.raises(AssertionError):
        check_one_way(calls)
