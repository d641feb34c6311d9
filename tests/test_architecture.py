"""The layers point one way (docs/architecture.md): checked on the source, import by import."""

import ast
import pathlib

import networkx as nx
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _modules(package):
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        yield name, path


def _imports(name, path, top_level_only=False):
    """(imported module, line) of every import in the file; relative imports resolved."""
    tree = ast.parse(path.read_text())
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    nodes = tree.body if top_level_only else ast.walk(tree)
    for node in nodes:
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module
            yield module, node.lineno
            for alias in node.names:  # "from . import datasets" imports a module
                if f"{module}.{alias.name}" in _ALL:
                    yield f"{module}.{alias.name}", node.lineno


_ALL = {name for package in ("granalytics", "sim") for name, _ in _modules(package)}


def _is_entry(name):
    return name.endswith("__main__")


def test_no_library_module_imports_argparse_or_the_command_line():
    offenders = [f"{name}:{line} imports {module}"
                 for name, path in _modules("granalytics")
                 if not (name == "granalytics.cli" or name.startswith("granalytics.cli.") or _is_entry(name))
                 for module, line in _imports(name, path)
                 if module == "argparse" or module == "granalytics.cli" or module.startswith("granalytics.cli.")]
    assert offenders == []


def test_granalytics_never_imports_sim():
    """The simulator depends on granalytics' run-file contract, never the other way round (its sweep
    command is ``python -m sim sweep``, not a granalytics command)."""
    edges = [(name, module, line) for name, path in _modules("granalytics") for module, line in _imports(name, path)
             if module == "sim" or module.startswith("sim.")]
    assert edges == []


def test_sim_uses_the_base_and_core_layers_only():
    """sim imports granalytics through granalytics.core (the data model, run files, the manifest's
    schema) and granalytics.base (errors, output files, Ctrl-C, resource checks, the dask client),
    and nothing else."""
    offenders = [f"{name}:{line} imports {module}"
                 for name, path in _modules("sim")
                 for module, line in _imports(name, path)
                 if module.startswith("granalytics") and _layer(module) not in ("core", "base")]
    assert offenders == []


@pytest.mark.parametrize("package, allowed", [("base", ("base", "_version")), ("core", ("base", "core", "_version"))])
def test_the_base_and_the_core_import_nothing_of_granalytics_above_them(package, allowed):
    offenders = [f"{name}:{line} imports {module}"
                 for name, path in _modules(f"granalytics/{package}")
                 for module, line in _imports(name, path)
                 if module.startswith("granalytics") and _layer(module) not in allowed]
    assert offenders == []


def test_importing_the_core_loads_the_run_file_contract_only():
    """``import granalytics.core`` loads the contract (snapshot, format, reader, writer, subset and the
    reader's helpers) and the base modules it stands on, not the manifest, the dask client, dask or SciPy."""
    import subprocess
    import sys

    code = "import sys, granalytics.core; print(' '.join(sorted(m for m in sys.modules if m.startswith(('granalytics', 'dask', 'distributed', 'scipy', 'numba')))))"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    contract = {"snapshot", "format", "reader", "writer", "subset", "hdf5_file", "windows"}
    base = {"errors", "validation", "files", "interrupts", "resources"}
    assert proc.stdout.split() == sorted({"granalytics", "granalytics._version", "granalytics.base", "granalytics.core"}
                                         | {f"granalytics.core.{m}" for m in contract}
                                         | {f"granalytics.base.{m}" for m in base})


def test_the_contract_and_the_simulator_load_no_analysis_library():
    """`import sim.run` (and so granalytics.core) loads neither pandas, NetworkX, SciPy's sparse
    graphs, scikit-learn, igraph, matplotlib nor any module of granalytics above the core."""
    import subprocess
    import sys

    heavy = ("pandas", "networkx", "scipy.sparse", "sklearn", "igraph", "matplotlib", "dask")
    above = tuple(f"granalytics.{layer}" for layer in ("identification", "analysis", "convert", "export", "report", "cli"))
    code = (f"import sys, sim.run; print(','.join(m for m in sys.modules if m in {heavy!r} "
            f"or m.startswith({above!r})))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == ""


#: the layers of granalytics, lowest first: a module imports only modules of its own layer or of a
#: lower one (docs/architecture.md).
LAYERS = {"_version": 0, "base": 0, "core": 1, "identification": 2, "convert": 2, "analysis": 3,
          "export": 4, "report": 4, "datasets": 4, "cli": 5, "__main__": 5}


def _layer(module):
    parts = module.split(".")
    return parts[1] if parts[0] == "granalytics" and len(parts) > 1 else None


def test_every_module_lives_in_a_layer_and_imports_only_downwards():
    names = dict(_modules("granalytics"))
    unplaced = [name for name in names if name != "granalytics" and _layer(name) not in LAYERS]
    assert unplaced == []
    offenders = [f"{name}:{line} imports {module}"
                 for name, path in names.items() if name != "granalytics" and not _is_entry(name)
                 for module, line in _imports(name, path)
                 if _layer(module) in LAYERS and LAYERS[_layer(module)] > LAYERS[_layer(name)]]
    assert offenders == []


def _draws(module):
    return module in ("granalytics.report", "matplotlib") or module.startswith(("granalytics.report.", "matplotlib."))


@pytest.mark.parametrize("package", ["granalytics/analysis", "granalytics/identification", "granalytics/core",
                                     "granalytics/base"])
def test_only_the_report_layer_and_the_command_line_draw(package):
    """The analysis, identification, core and base layers compute; no module of theirs imports
    the report layer or matplotlib, not even inside a function (figures are drawn and files
    written by granalytics.report from their results)."""
    offenders = [f"{name}:{line} imports {module}" for name, path in _modules(package)
                 for module, line in _imports(name, path) if _draws(module)]
    assert offenders == []


def test_matplotlib_is_imported_by_the_report_layer_and_the_command_line_only():
    offenders = [f"{name}:{line} imports {module}" for name, path in _modules("granalytics")
                 if _layer(name) not in ("report", "cli")
                 for module, line in _imports(name, path) if module == "matplotlib" or module.startswith("matplotlib.")]
    assert offenders == []


def test_identification_and_convert_know_nothing_of_each_other():
    offenders = [f"{name} imports {module}" for name, path in _modules("granalytics")
                 for module, _ in _imports(name, path) if {_layer(name), _layer(module)} == {"identification", "convert"}]
    assert offenders == []


def test_the_lazy_package_still_exports_every_public_name():
    import granalytics

    assert all(getattr(granalytics, name) is not None for name in granalytics.__all__)
    assert set(granalytics.__all__) <= set(dir(granalytics))
    import granalytics.analysis.sensitivity  # noqa: F401
    import granalytics.identification  # noqa: F401  (the layer; granalytics.identify is the function)

    assert callable(granalytics.identify) and callable(granalytics.sensitivity)
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        granalytics.not_a_name  # noqa: B018


@pytest.mark.parametrize("package", ["granalytics", "sim"])
def test_no_import_cycle_between_modules(package):
    """Module-level imports only (a function-level import is a deliberate late edge). A package's
    ``__init__`` importing its own submodules (to re-export them) is not counted; a submodule
    importing its package back (``from .. import __version__``) is."""
    graph = nx.DiGraph()
    names = dict(_modules(package))
    for name, path in names.items():
        for module, _ in _imports(name, path, top_level_only=True):
            if module in names and module != name and not module.startswith(name + "."):
                graph.add_edge(name, module)
    cycles = list(nx.simple_cycles(graph))
    assert cycles == []


def test_the_two_packages_do_not_import_each_other_at_module_level():
    from_granalytics = {m for name, path in _modules("granalytics") for m, _ in _imports(name, path, top_level_only=True)}
    assert not any(m == "sim" or m.startswith("sim.") for m in from_granalytics)
