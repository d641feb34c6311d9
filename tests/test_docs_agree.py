"""The documents say the same thing about the same fact (a new user compared them)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
DOCS = [ROOT / "README.md", ROOT / "datasets" / "README.md", *sorted((ROOT / "docs").glob("*.md")),
        *sorted((ROOT / "docs" / "notebooks").glob("*.ipynb"))]


@pytest.mark.parametrize("wrong, right", [
    # the simulator is bit-identical for any thread count (docs/simulator.md, tests/test_sim_run.py)
    (r"for a given seed and thread count|seed\s+and thread count give", "the thread count does not matter"),
    # the yield is a number fraction (granalytics.analysis.stats.frame_stats)
    (r"yield \(mass fraction", "particles in granules / particles"),
    # the numba backend of GNA is called 'fast' (granalytics.identification.BACKENDS)
    (r"scipy / numba backends", "the `fast` (numba) backend"),
])
def test_no_document_contradicts_the_code(wrong, right):
    found = [f"{path.relative_to(ROOT)}" for path in DOCS if re.search(wrong, path.read_text())]
    assert not found, f"{found} say {wrong!r}; the code says {right}"


def test_the_backend_names_the_readme_gives_are_the_command_lines():
    from granalytics.identification import BACKENDS

    readme = (ROOT / "README.md").read_text()
    assert all(f"`{name}`" in readme or f" {name} " in readme or f"{name} /" in readme for name in BACKENDS)
