"""How long granule track ids persist under the two continuation rules: the table of docs/tracking.md.

Usage: python scripts/track_persistence.py [--datasets lab-cg1,lab-cg3,paper-cg3] [--window 3:3.5]
       [--every 4] [--touch-gap 0.02]

For each bundled run and cohesion convention ("acting", "bridge") it identifies the granules of
every frame in the revolution window once (GNA at the paper's thresholds, C_agg = 0.6,
A_agg = 20°) and tracks them (``track_granules``) on every frame and on every ``--every``-th frame
of the window, under ``continuation="strict"`` and ``"main"``. Per row:

- ``tracks``: number of tracks;
- ``>= 2 frames``: share of tracks seen in two frames or more;
- ``particle-weighted``: the same share weighted by particles, i.e. of the (particle, frame)
  memberships of granules, the share whose granule's track is seen in two frames or more;
- ``median life``: median over tracks of the observed life, last frame's time minus first
  frame's [revolutions] (0 for a track seen in one frame); ``of those ≥ 2``: the same median over
  the tracks seen in two frames or more;
- ``particle-weighted median life``: the median of the same life over the (particle, frame)
  memberships: how long the id lives of the granule a granule particle is in.

Then, for the last dataset (paper-cg3 by default), why bonds come and go under the acting
convention: per frame of the window, the share of the near-touching wet pairs (bridge volume > 0
and gap < ``--touch-gap`` × (R_i + R_j), i.e. the pair's mean diameter) that are touching (gap <= 0,
hence no acting cohesion), the same share among all wet pairs, and what became at the next frame
of the bonds GNA kept (acting): kept again, touching, or otherwise lost.
"""

from __future__ import annotations

import argparse

import numpy as np

import granalytics as ga
from granalytics.analysis.tracking import track_granules
from granalytics.datasets import open_dataset

C_AGG, A_AGG_DEG = 0.6, 20.0
CONVENTIONS = ("acting", "bridge")
RULES = ("strict", "main")


def identified(run, window, cohesion):
    """Granule labels, particle ids and revolutions of every frame of ``window`` [revolutions]."""
    labels, ids, revolutions = [], [], []
    for snapshot in run.select(revolutions=window):
        labels.append(ga.identify(snapshot, c_agg=C_AGG, a_agg_deg=A_AGG_DEG, cohesion=cohesion).labels)
        ids.append(snapshot.ids)
        revolutions.append(snapshot.revolutions)
    return labels, ids, np.asarray(revolutions)


def weighted_median(values, weights):
    """The median of ``values`` with integer ``weights`` (the lower of two middle values)."""
    order = np.argsort(values, kind="stable")
    cumulative = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cumulative, 0.5 * cumulative[-1])])


def persistence(tracks, revolutions):
    """The persistence columns of one tracking (see the module docstring)."""
    table = tracks.tracks
    life = revolutions[table["last_frame"].to_numpy()] - revolutions[table["first_frame"].to_numpy()]
    lasting = (table["last_frame"] > table["first_frame"]).to_numpy()
    memberships = np.fromiter((sum(s) for s in table["sizes"]), dtype=np.int64, count=len(table))
    return {"tracks": len(table), "lasting": lasting.mean(), "weighted": memberships[lasting].sum() / memberships.sum(),
            "median_life": float(np.median(life)),
            "lasting_median_life": float(np.median(life[lasting])) if lasting.any() else np.nan,
            "weighted_median_life": weighted_median(life, memberships)}


def pair_keys(snapshot, mask):
    """One int64 key per contact of ``mask``: the pair's particle ids (smaller, larger)."""
    i, j = snapshot.ids[snapshot.contact_i[mask]], snapshot.ids[snapshot.contact_j[mask]]
    return np.minimum(i, j) * (int(snapshot.ids.max()) + 1) + np.maximum(i, j)


def touching(run, window, touch_gap):
    """Per frame: touching share of near-touching and of all wet pairs, and the fate at the next
    frame of the bonds GNA kept under the acting convention."""
    rows, previous = [], None
    for snapshot in run.select(revolutions=window):
        result = ga.identify(snapshot, c_agg=C_AGG, a_agg_deg=A_AGG_DEG, cohesion="acting")
        wet = snapshot.bridge_volume > 0
        contact = snapshot.gap <= 0
        diameter = snapshot.radius[snapshot.contact_i] + snapshot.radius[snapshot.contact_j]
        near = wet & (snapshot.gap < touch_gap * diameter)
        row = {"revolutions": snapshot.revolutions, "near": (near & contact).sum() / near.sum(),
               "wet": (wet & contact).sum() / wet.sum()}
        if previous is not None:  # the bonds kept at the previous frame, now
            row.update(still_kept=np.isin(previous, pair_keys(snapshot, result.kept)).mean(),
                       now_touching=np.isin(previous, pair_keys(snapshot, wet & contact)).mean())
        previous = pair_keys(snapshot, result.kept)
        rows.append(row)
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", default="lab-cg1,lab-cg3,paper-cg3")
    parser.add_argument("--window", default="3:3.5", help="revolutions R0:R1")
    parser.add_argument("--every", type=int, default=4, help="the thinned sampling: every N-th frame of the window")
    parser.add_argument("--touch-gap", type=float, default=0.02,
                        help="near-touching: gap below this fraction of the pair's mean diameter")
    args = parser.parse_args()
    window = tuple(float(x) for x in args.window.split(":"))
    names = args.datasets.split(",")
    print(f"GNA C_agg = {C_AGG}, A_agg = {A_AGG_DEG:g}°, revolutions {window[0]:g}–{window[1]:g}, min_fragment 2\n")
    print("| run | cohesion | frames | Δ (rev) | rule | tracks | ≥ 2 frames | particle-weighted | median life (rev) "
          "| of those ≥ 2 | particle-weighted median life (rev) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in names:
        with open_dataset(name) as run:
            for cohesion in CONVENTIONS:
                labels, ids, revolutions = identified(run, window, cohesion)
                for every in (1, args.every):
                    picked = slice(None, None, every)
                    revs = revolutions[picked]
                    spacing = float(np.median(np.diff(revs)))
                    for rule in RULES:
                        tracks = track_granules(labels[picked], ids[picked], revs, continuation=rule)
                        p = persistence(tracks, revs)
                        print(f"| {name} | {cohesion} | {len(revs)} | {spacing:.2f} | {rule} | {p['tracks']} "
                              f"| {p['lasting']:.1%} | {p['weighted']:.1%} | {p['median_life']:.2f} "
                              f"| {p['lasting_median_life']:.2f} | {p['weighted_median_life']:.2f} |")
    with open_dataset(names[-1]) as run:
        rows = touching(run, window, args.touch_gap)
    near = np.array([r["near"] for r in rows])
    wet = np.array([r["wet"] for r in rows])
    kept = np.array([r["still_kept"] for r in rows[1:]])
    touch = np.array([r["now_touching"] for r in rows[1:]])
    print(f"\n{names[-1]}, {len(rows)} frames: touching share of the near-touching wet pairs (gap < "
          f"{args.touch_gap:g}·d) {near.mean():.1%} (frames {near.min():.1%}–{near.max():.1%}); of all wet pairs "
          f"{wet.mean():.1%} ({wet.min():.1%}–{wet.max():.1%})")
    print(f"bonds kept (acting) at one frame: kept again at the next {kept.mean():.1%} "
          f"({kept.min():.1%}–{kept.max():.1%}), touching at the next {touch.mean():.1%} "
          f"({touch.min():.1%}–{touch.max():.1%}), otherwise lost {1 - kept.mean() - touch.mean():.1%}")


if __name__ == "__main__":
    main()
