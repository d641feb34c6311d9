"""One granule followed over frames by its track id: the figure of docs/tracking.md.

Usage: python scripts/granule_track_figure.py [--dataset lab-cg1] [--window 3:6] [--frames 10] [--out track.png]
       [--vtk DIR]

Tracks the granules of a bundled run over the window (GNA, the paper's thresholds, acting
cohesion), picks the longest-lived track (ties: the largest granule) and draws the frames of its
life side by side: every particle in grey, the granule's particles in colour, with the track id,
size and time in each panel's title. With ``--vtk DIR`` it also writes the ParaView export of
the same frames (``granalytics export-vtk``), whose ``granule_track`` point field carries the same
id, and checks that it does.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

import granalytics as ga
from granalytics.datasets import open_dataset


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="lab-cg1")
    parser.add_argument("--window", default="3:6", help="revolutions R0:R1")
    parser.add_argument("--frames", type=int, default=10, help="panels (the first frames of the track's life)")
    parser.add_argument("--out", default="build/granule_track.png")
    parser.add_argument("--vtk", help="also write the ParaView export of the track's frames into this folder")
    args = parser.parse_args()
    lo, hi = (float(x) for x in args.window.split(":"))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open_dataset(args.dataset) as run:
        frames = run.select(revolutions=(lo, hi))
        table = ga.particle_table(frames)
        tracked = table[table.granule_track >= 0]
        life = tracked.groupby("granule_track").frame.nunique()
        size = tracked.groupby("granule_track").size()
        track = max(life.index, key=lambda t: (life[t], size[t]))
        shown = sorted(tracked.loc[tracked.granule_track == track, "frame"].unique())[:args.frames]
        print(f"{args.dataset}: track {track} lives {life[track]} frames "
              f"({len(life[life >= args.frames])} tracks of {len(life)} live >= {args.frames} frames)")
        fig = plt.figure(figsize=(3.0 * min(5, len(shown)), 3.2 * ((len(shown) + 4) // 5)), layout="constrained")
        members = table.granule_track == track
        for k, frame in enumerate(shown):
            part = table[table.frame == frame]
            mine = part.granule_track == track
            centre = part.loc[mine, ["x", "y", "z"]].mean().to_numpy()
            near = np.linalg.norm(part[["x", "y", "z"]].to_numpy() - centre, axis=1) < 8 * part.radius.max()
            ax = fig.add_subplot((len(shown) + 4) // 5, min(5, len(shown)), k + 1, projection="3d")
            rest = part[near & ~mine]
            ax.scatter(rest.x, rest.y, rest.z, s=4, c="0.75", depthshade=False)
            ax.scatter(part.x[mine], part.y[mine], part.z[mine], s=40, c="C3", depthshade=False)
            ax.set_title(f"rev {part.revolutions.iloc[0]:.2f}: track {track}, {int(mine.sum())} particles", fontsize=8)
            ax.set_xticks([]), ax.set_yticks([]), ax.set_zticks([])
            for axis, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):  # the granule's centre
                axis(c - 4 * part.radius.max(), c + 4 * part.radius.max())
        fig.suptitle(f"{args.dataset}: one granule keeps its track id (GNA, C_agg = 0.6, A_agg = 20°, acting)",
                     fontsize=10)
        os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
        fig.savefig(args.out, dpi=110)
        print(f"wrote {args.out}")
        if args.vtk:  # the same frames and identification, so the same track ids
            import meshio

            from granalytics.cli import main as cli

            cli(["export-vtk", str(run.path), "--out", args.vtk, "--window-rev", args.window, "--quiet", "--overwrite"])
            for frame in shown:
                mesh = meshio.read(os.path.join(args.vtk, f"frame_{int(frame):05d}.vtu"))
                ids = mesh.point_data["id"][mesh.point_data["granule_track"] == track]
                expected = table.loc[(table.frame == frame) & members, "id"]
                assert sorted(ids) == sorted(expected), f"frame {frame}: the export's track {track} differs"
            print(f"ParaView: open {args.vtk}/run.pvd and colour by granule_track; track {track} is the red granule "
                  f"(checked in the {len(shown)} exported frames)")

if __name__ == "__main__":
    main()
