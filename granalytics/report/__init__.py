"""The report layer: every result leaves granalytics through here, as files or as figures.

- :func:`save` ``(result, path_or_folder, *, overwrite=False, ...)`` writes any result
  (:func:`granalytics.save`), :func:`draw` ``(result, ...)`` draws it (:func:`granalytics.draw`);
  both dispatch on the result's type (:mod:`.registry`); :func:`output_paths` names the files of a
  result type, checked before the work. The command line writes its outputs through the same
  functions.
- :mod:`.files`: the output checks made before the work, the writers of tables, figures and JSON,
  and outputs of several files written as one.
- :mod:`.tables`: results as text (numbers with their errors, the CG table).
- :mod:`.labels`: the labels file of ``granalytics identify``.
- :mod:`.figures`: the figures, one module per subject.

The analyses return result objects and never touch the disk; this layer stands above them
(``docs/architecture.md``).
"""

__all__ = ["save", "draw", "output_paths", "output_names"]


def __getattr__(name):
    # save and draw load the analyses whose results they know; report.files alone (used by the
    # exporters and the dataset builder) stays light
    if name in __all__:
        from granalytics.report import registry

        return getattr(registry, name)
    raise AttributeError(f"module 'granalytics.report' has no attribute {name!r}")
