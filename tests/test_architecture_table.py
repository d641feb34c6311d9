"""docs/architecture.md's module table matches the tree: every module of granalytics is listed,
and every module the table lists exists."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "granalytics"
DOC = ROOT / "docs" / "architecture.md"


def _table_rows(text):
    """The rows of the table under the heading 'The tree, module by module'."""
    section = text.split("## The tree, module by module", 1)[1].split("\n## ", 1)[0]
    return [line for line in section.splitlines() if line.startswith("| `")]


def listed_modules(text) -> set:
    """Module paths (relative to granalytics/) the table names: in the first cell every backticked
    ``*.py``, a name without a folder taking the folder of the name before it (``identification/gna.py``,
    ``dbscan.py``); in the description, names with their folder only."""
    modules = set()
    for row in _table_rows(text):
        cells = row.split(" | ")
        folder = ""
        for name in re.findall(r"`([\w/]+\.py)`", cells[0]):
            name = name.removeprefix("granalytics/")
            if "/" in name:
                folder = name.rsplit("/", 1)[0] + "/"
                modules.add(name)
            else:
                modules.add(folder + name)
        for cell in cells[1:]:
            modules.update(name for name in re.findall(r"`([\w/]+\.py)`", cell)
                           if "/" in name and (PACKAGE / name.split("/")[0]).is_dir())
    return modules


def tree_modules() -> set:
    return {str(path.relative_to(PACKAGE)) for path in PACKAGE.rglob("*.py")
            if "__pycache__" not in path.parts and not (path.name == "__init__.py" and path.parent != PACKAGE)
            and path.name != "_version.py"}


def test_the_module_table_lists_every_module_of_the_tree():
    missing = tree_modules() - listed_modules(DOC.read_text())
    assert not missing, f"modules missing from docs/architecture.md's table: {sorted(missing)}"


def test_every_module_the_table_lists_exists():
    listed = {name for name in listed_modules(DOC.read_text()) if not name.endswith("/__init__.py")}
    stale = {name for name in listed if not (PACKAGE / name).is_file()}
    assert not stale, f"docs/architecture.md lists modules that are not in the tree: {sorted(stale)}"


def test_the_table_reader_reads_folders_and_bare_names():
    text = ("## The tree, module by module\n\n| module | what it is |\n| --- | --- |\n"
            "| `a/b.py`, `c.py` | x (`a/d.py`, `docs/e.py`, `f.py`) |\n\n## Next\n| `g.py` | y |\n")
    names = listed_modules(text)
    assert {"a/b.py", "a/c.py"} <= names and "f.py" not in names and "g.py" not in names
