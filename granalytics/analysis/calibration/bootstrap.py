"""The moving-block bootstrap of a simulated size distribution over a window's frames: the mean over
the frames of every grid point with its error (:func:`simulated_mean`), and the confidence region of
the best grid point, made of the bootstrap replicas' own best points (:func:`bootstrap_region`)
(docs/calibration.md, "The distance and the fit").

Frames closer than a granule's lifetime are correlated, so the frames are resampled in blocks of
``block_rev`` revolutions (:func:`check_block` refuses a block that spans the whole window); each
run of a replica set is resampled on its own.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from granalytics.base.errors import ParameterError

__all__ = ["check_block", "SimulatedMean", "simulated_mean", "bootstrap_region"]


def check_block(revolutions, block_rev) -> None:
    """Refuse a bootstrap block that spans the whole window (or a window of one frame): its
    replicas would all be the window itself, and the region a single point."""
    n = np.size(revolutions)
    span = float(revolutions[-1] - revolutions[0])
    if n < 3 or not block_rev < span:
        raise ParameterError(f"block_rev = {block_rev:g} revolutions: the bootstrap needs blocks shorter than the "
                             f"window ({n} frames over {span:.3g} revolutions), or its replicas are the window itself "
                             "and the confidence region one point; give a shorter --block-rev or a longer window")


def _bootstrap_weights(rng, revolutions, n_boot, block_rev) -> np.ndarray:
    """(n_boot, F) frame counts of moving-block bootstrap replicas of F time-ordered frames, whose
    blocks :func:`check_block` has let through (shorter than the window)."""
    n = revolutions.size
    per_rev = (n - 1) / (revolutions[-1] - revolutions[0])
    length = max(1, round(block_rev * per_rev))
    n_blocks = math.ceil(n / length)
    starts = rng.integers(0, n - length + 1, size=(n_boot, n_blocks))
    picks = (starts[:, :, None] + np.arange(length)).reshape(n_boot, -1)[:, :n]
    weights = np.zeros((n_boot, n))
    np.add.at(weights, (np.repeat(np.arange(n_boot), n), picks.ravel()), 1.0)
    return weights


class SimulatedMean(NamedTuple):
    """The simulated cumulative passing at the compared edges (``p``, its bootstrap error ``err_p``)
    and fractions per class (``f``, ``err_f``) at every grid point (A, C, ·), and the bootstrap
    replicas of the passing ``boot_p`` (B, A, C, E)."""

    p: np.ndarray
    err_p: np.ndarray
    f: np.ndarray
    err_f: np.ndarray
    boot_p: np.ndarray | None


def simulated_mean(grids, used, rng, n_boot, block_rev) -> SimulatedMean:
    """Mean over the replicas' frames and its block bootstrap (each replica resampled on its own)."""
    n_a, n_c, n_bins = grids[0].volumes.shape[1:]
    sim_p, sim_f, boot_p, boot_f = 0.0, 0.0, 0.0, 0.0
    for g in grids:
        passing = g.passing[..., used].reshape(g.volumes.shape[0], -1)  # (F, A·C·E)
        fractions = g.fractions.reshape(g.volumes.shape[0], -1)
        weights = _bootstrap_weights(rng, g.revolutions, n_boot, block_rev)
        weights /= weights.sum(axis=1, keepdims=True)
        sim_p = sim_p + passing.mean(axis=0) / len(grids)
        sim_f = sim_f + fractions.mean(axis=0) / len(grids)
        boot_p = boot_p + weights @ passing / len(grids)
        boot_f = boot_f + weights @ fractions / len(grids)
    n_e = int(used.sum())
    boot_p = boot_p.reshape(-1, n_a, n_c, n_e)
    return SimulatedMean(p=sim_p.reshape(n_a, n_c, n_e), err_p=boot_p.std(axis=0, ddof=1),
                      f=sim_f.reshape(n_a, n_c, n_bins), err_f=boot_f.reshape(-1, n_a, n_c, n_bins).std(axis=0, ddof=1),
                      boot_p=boot_p)


def bootstrap_region(boot_chi2, best, level):
    """Each bootstrap replica's best grid point (points tied with it, which give the same
    distribution, share its vote, so that thresholds that change nothing fill the region); the
    region is the most voted points holding ``level`` of the votes, and always the best point."""
    n_boot = boot_chi2.shape[0]
    low = boot_chi2.min(axis=1, keepdims=True)
    tied = boot_chi2 <= low + 1e-12 * np.maximum(np.abs(low), 1.0)
    freq = (tied / tied.sum(axis=1, keepdims=True)).sum(axis=0) / n_boot
    order = np.argsort(-freq, kind="stable")
    take = int(np.searchsorted(np.cumsum(freq[order]), level - 1e-12)) + 1
    region = np.zeros(freq.size, dtype=bool)
    region[order[:take]] = True
    region &= freq > 0
    region[best] = True
    return freq, region
