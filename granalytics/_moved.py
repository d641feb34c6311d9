"""Old import paths of modules that moved into the layer folders (core, identify, analysis,
convert, export, datasets): ``import granalytics.stats`` still works for one release, with a
DeprecationWarning naming the new path, and gives the very module object of the new path (so a
``monkeypatch`` or an ``isinstance`` check on either name sees the same thing).

One mechanism for all of them: a finder on ``sys.meta_path`` (installed by
``granalytics/__init__.py``) that knows only the names in :data:`MOVED`.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module path -> new module path (removed in the release after 0.x)
MOVED = {
    "granalytics.snapshot": "granalytics.core.snapshot",
    "granalytics.errors": "granalytics.core.errors",
    "granalytics.files": "granalytics.core.files",
    "granalytics.manifest": "granalytics.core.manifest",
    "granalytics._windows": "granalytics.core._windows",
    "granalytics._threading": "granalytics.core._threading",
    "granalytics.bed": "granalytics.core.bed",
    "granalytics.io.format": "granalytics.core.format",
    "granalytics.io.writer": "granalytics.core.writer",
    "granalytics.io.reader": "granalytics.core.reader",
    "granalytics.io.native": "granalytics.core.native",
    "granalytics.io.subset": "granalytics.core.subset",
    "granalytics.cohesion": "granalytics.identify.cohesion",
    "granalytics.contacts": "granalytics.identify.contacts",
    "granalytics.edges": "granalytics.identify.edges",
    "granalytics._kernels": "granalytics.identify._kernels",
    "granalytics.granules": "granalytics.identify.granules",
    "granalytics.frames": "granalytics.analysis.frames",
    "granalytics.stats": "granalytics.analysis.stats",
    "granalytics.metrics": "granalytics.analysis.metrics",
    "granalytics.sensitivity": "granalytics.analysis.sensitivity",
    "granalytics.compare": "granalytics.analysis.method_comparison",
    "granalytics.cg": "granalytics.analysis.cg",
    "granalytics.table": "granalytics.analysis.table",
    "granalytics.confinement": "granalytics.analysis.confinement",
    "granalytics.tracking": "granalytics.analysis.tracking",
    "granalytics.study": "granalytics.analysis.study",
    "granalytics.io.readers": "granalytics.convert.registry",
    "granalytics.io.lammps": "granalytics.convert.lammps",
    "granalytics.io.yade": "granalytics.convert.yade",
    "granalytics.io._text": "granalytics.convert._text",
    "granalytics.synthetic": "granalytics.datasets.synthetic",
    "granalytics.io.vtk": "granalytics.export.vtk",
}


def moved_warning(old):
    """The DeprecationWarning's text for the old path ``old`` (a key of :data:`MOVED`)."""
    return (f"{old} moved to {MOVED[old]}; import it from there (or from the top-level granalytics package): "
            f"the old path goes in the next release")


class _MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Resolves an old module path to the module at its new path. The import machinery sets the
    returned module's ``__spec__`` to the old name's; :meth:`exec_module` puts the real one back."""

    def __init__(self):
        self._specs = {}

    def find_spec(self, fullname, path=None, target=None):
        if fullname not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        # stacklevel 2: the importer's line (warnings skips importlib's own frames)
        warnings.warn(moved_warning(spec.name), DeprecationWarning, stacklevel=2)
        module = importlib.import_module(MOVED[spec.name])
        self._specs[module.__name__] = module.__spec__
        return module

    def exec_module(self, module):
        """Nothing to run (the module was executed under its new name): restore its own spec."""
        module.__spec__ = self._specs.pop(module.__name__, module.__spec__)


def install():
    """Put the finder on ``sys.meta_path`` once (idempotent)."""
    if not any(isinstance(finder, _MovedModuleFinder) for finder in sys.meta_path):
        sys.meta_path.append(_MovedModuleFinder())
