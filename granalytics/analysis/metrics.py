"""The per-frame granulation statistics: one registry read by stats, cg, study, sensitivity, the
figures and the command line.

Each :class:`Metric` is a column of :func:`granalytics.frame_stats` with its label (for axes and
tables), the paper's figure that shows it, the format of its printed values and whether it is a
*headline* metric (compared across CG levels, threshold grids and parameter studies). Adding a
statistic: compute it in ``frame_stats``, register it here; every consumer that iterates over
:data:`METRICS` or :data:`HEADLINE` then carries it (steady-state tables, CG tables, figures).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Metric", "METRICS", "HEADLINE", "STEADY", "BY_FIGURE"]


@dataclass(frozen=True)
class Metric:
    """One per-frame statistic.

    Attributes
    ----------
    name : str
        Column of :func:`granalytics.frame_stats`.
    label : str
        Axis / table label.
    figure : str
        The paper's figure that shows it ("" if none).
    fmt : str
        Format of a printed value (``format(value, fmt)``).
    headline : bool
        Compared across CG levels, threshold grids and parameter studies.
    """

    name: str
    label: str
    figure: str = ""
    fmt: str = ".4g"
    headline: bool = False


#: the registry, in the order of steady-state tables
METRICS = {m.name: m for m in (
    Metric("n_granules_norm", "N_g / N", "Fig 4", ".4f", headline=True),
    Metric("mean_volume_norm", "⟨V_g⟩ / V_p", "Fig 3", ".3g", headline=True),
    Metric("yield_fraction", "yield", "Fig 6", ".3f", headline=True),
    Metric("mean_granule_size", "particles per granule", "", ".3g"),
)}
#: the headline metrics (yield first, as the paper reports them)
HEADLINE = ("yield_fraction", "mean_volume_norm", "n_granules_norm")
#: the metrics of a steady-state table (:func:`granalytics.steady_state`'s default)
STEADY = tuple(METRICS)
assert set(HEADLINE) == {name for name, m in METRICS.items() if m.headline}

#: the headline metrics in the order of the paper's figures (Figs 3, 4, 6)
BY_FIGURE = tuple(sorted(HEADLINE, key=lambda name: METRICS[name].figure))
