"""What the figures share: axis labels and ticks of granule sizes, legend keys, cell edges of heatmaps."""

from __future__ import annotations

import numpy as np

__all__ = ["SIZE_LABELS", "plain_log_ticks", "sizes_unit", "add_key", "legend_keys_last", "steady_key", "cell_edges"]


#: Axis labels of granule sizes in each unit (:data:`granalytics.analysis.stats.SIZE_UNITS`).
SIZE_LABELS = {"particles": "particles per granule",
               "original": "original-particle equivalents per granule (α³·n)"}


def plain_log_ticks(axis):
    """Plain numbers on a logarithmic axis ("6", "0.2", "1e-05"), never "6×10⁰": matplotlib's own
    choice of which minor ticks to label (all of them below a decade, some below 2.5 decades)."""
    from matplotlib.ticker import LogFormatter

    class Plain(LogFormatter):
        def _num_to_string(self, x, vmin, vmax):
            return f"{x:g}"

    axis.set_major_formatter(Plain(labelOnlyBase=False))
    axis.set_minor_formatter(Plain(labelOnlyBase=False, minor_thresholds=(1, 0.4)))


def sizes_unit(table, size_unit=None) -> str:
    """The size unit of a table of :func:`~granalytics.size_distribution` or
    :func:`~granalytics.coalescence_kernel` (its ``attrs``), unless given."""
    unit = size_unit or getattr(table, "attrs", {}).get("size_unit", "particles")
    if unit not in SIZE_LABELS:
        from granalytics.base.errors import ParameterError

        raise ParameterError(f"size_unit must be one of {', '.join(SIZE_LABELS)}, got {unit!r}")
    return unit


def add_key(ax, label, **style):
    """A legend entry that explains a style (drawn once per axes, nothing on the plot)."""
    if label not in ax.get_legend_handles_labels()[1]:
        if style.pop("patch", False):
            ax.fill_between([], [], [], label=label, **style)
        else:
            ax.plot([], [], label=label, **style)


def legend_keys_last(ax, **kwargs):
    """The axes' legend with the curves first and the keys of :func:`add_key` (band, open
    markers) after them."""
    handles, labels = ax.get_legend_handles_labels()
    keyed = [lab.startswith(("band:", "open marker:")) for lab in labels]
    order = [i for i, k in enumerate(keyed) if not k] + [i for i, k in enumerate(keyed) if k]
    return ax.legend([handles[i] for i in order], [labels[i] for i in order], **kwargs)


def steady_key(window, x="revolutions", error="block s.e.m."):
    """Legend handles and labels of the steady-state window (shaded) and its mean ± error (a
    line over a band), in grey: one entry each, whatever the colours of the curves."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    unit = "rev" if x == "revolutions" else "s"
    return ([Patch(color="0.9"), (Patch(color="0.5", alpha=0.3, lw=0), Line2D([], [], color="0.3", lw=2))],
            [f"steady-state window [{window[0]:g}, {window[1]:g}] {unit}", f"steady-state mean ± {error}"])


def cell_edges(values):
    """Cell edges around sorted centre values (for pcolormesh)."""
    values = np.asarray(values, dtype=float)
    if values.size == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    mid = (values[1:] + values[:-1]) / 2
    return np.r_[values[0] - (mid[0] - values[0]), mid, values[-1] + (values[-1] - mid[-1])]
