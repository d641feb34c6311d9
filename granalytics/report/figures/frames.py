"""One identified frame in 3-D, coloured by granule."""

from __future__ import annotations

import numpy as np

__all__ = ["frame_figure"]


def frame_figure(result, ax=None, max_colours=20):
    """3-D scatter of one identified frame, particles sized by radius and coloured by granule
    (the largest ``max_colours`` granules in distinct colours, other granules grey, free
    particles light grey)."""
    import matplotlib.pyplot as plt

    s = result.snapshot
    if ax is None:
        fig = plt.figure(figsize=(6, 6))
        ax = fig.add_subplot(projection="3d")
    colours = np.full((s.n_particles, 4), (0.85, 0.85, 0.85, 0.25))
    member = result.labels >= 0
    colours[member] = (0.45, 0.45, 0.45, 0.8)
    palette = plt.get_cmap("tab20")
    for g in range(min(result.n_granules, max_colours)):
        colours[result.labels == g] = palette(g % 20)
    lo, hi = s.position.min(axis=0) - s.radius.max(), s.position.max(axis=0) + s.radius.max()
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_aspect("equal")
    # marker diameter = the particle's diameter on the axes' scale (points per metre from the axes'
    # width and the longest data span; exact for the view straight along an axis)
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72
    points_per_m = width_pt / float((hi - lo).max()) / 1.6  # a 3-D box fills ~1/1.6 of the axes' width
    size = (2 * s.radius * points_per_m) ** 2
    ax.scatter(s.position[:, 0], s.position[:, 1], s.position[:, 2], c=colours, s=size, depthshade=False)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"t = {s.time:.3f} s: {result.n_granules} granules, yield {result.n_granulated / s.n_particles:.2f}")
    return ax.figure
