"""The statistics of a run kept in place of its frames.

A run too large to keep whole (10⁵–10⁶ particles, hundreds of frames), or one made in parts on
machines that did not keep their disks (``sim run --resume-from``), is analysed frame by frame as
it is made; what is kept is a few MB: every frame's granule statistics, the bed's, and its granule
sizes, with the run's metadata and how the granules were identified. :func:`~granalytics.compare_cg`
takes such :class:`RunStatistics` wherever it takes a run file, so that the kept run is compared
with others (Figs 3–6, the table) as if its frames were there.

On disk it is a folder (``granalytics.save(statistics, folder)``, :meth:`RunStatistics.read`):

``frames.csv``
    One row per frame, by the run's frame index ``frame``: the columns of
    :func:`~granalytics.analysis.confinement.confinement_timeseries` (the granule statistics of
    :func:`~granalytics.run_stats`, then the bed's wall share, coordination, angle [°] and kinetic
    energy).
``sizes.csv``
    ``frame, size, count``: how many granules of each size (particles) the frame holds.
``meta.json``
    ``{"meta": the run's RunMeta, "method": ..., "params": ...}``: the identification's method and
    its parameters, every one (defaults included).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from granalytics.base.errors import ParameterError
from granalytics.core.snapshot import RunMeta

__all__ = ["RunStatistics", "RUN_STATISTICS_FILES"]

#: parameters that change how fast granules are found, not which: not compared between statistics
_SPEED_ONLY = ("backend",)
#: the files of a folder of run statistics, in the order they are written
RUN_STATISTICS_FILES = ("frames.csv", "sizes.csv", "meta.json")


def _identification(method, params) -> dict:
    """Every parameter of the identification ``method`` with ``params`` (defaults filled in)."""
    from granalytics.identification import make_identifier

    return {k: v for k, v in make_identifier(method, **params).params().items() if k not in _SPEED_ONLY}


@dataclass
class RunStatistics:
    """Every kept frame's statistics of one run, in place of its frames.

    Attributes
    ----------
    meta : RunMeta
        The run's metadata (its system, drum, α and cost).
    timeseries : DataFrame
        One row per frame, increasing ``frame`` (the run's frame index), with ``time_s`` [s],
        ``revolutions`` and the metrics of :func:`~granalytics.analysis.confinement.confinement_timeseries`.
    sizes : list of int arrays
        The granule sizes (particles per granule) of each row's frame.
    method : str
        Identification method (:data:`granalytics.identification.METHODS`).
    params : dict
        Its parameters, every one (defaults filled in; ``backend`` left out).
    path : str
        Where the statistics were read from, or what they are of (named in messages).
    """

    meta: RunMeta
    timeseries: pd.DataFrame
    sizes: list
    method: str = "gna"
    params: dict = field(default_factory=dict)
    path: str = ""

    def __post_init__(self):
        frames = self.timeseries["frame"].to_numpy() if "frame" in self.timeseries else None
        if frames is None or len(self.sizes) != len(frames):
            raise ParameterError(f"{self.path or 'RunStatistics'}: needs a 'frame' column and one size array per row "
                                 f"(got {len(self.sizes)} for {len(self.timeseries)} rows)")
        if (np.diff(frames) <= 0).any():
            k = int(np.flatnonzero(np.diff(frames) <= 0)[0])
            raise ParameterError(f"{self.path or 'RunStatistics'}: frames not increasing (frame {frames[k + 1]} after "
                                 f"{frames[k]})")

    def __len__(self) -> int:
        return len(self.timeseries)

    @classmethod
    def of_frames(cls, frames, meta, frame_indices=None, method="gna", *, progress=False, path="", **params):
        """The statistics of ``frames`` (a Run, a RunSlice or snapshots) of a run with ``meta``.

        ``frame_indices`` are their indices in the run (default: those the frames give, their
        position in a plain sequence, after the part's first frame where ``meta`` is a part's,
        ``provenance["first_frame"]``); ``method`` and ``params`` identify the granules, as for
        :func:`~granalytics.run_stats`.
        """
        from granalytics.analysis.confinement import confinement_timeseries

        table, sizes = confinement_timeseries(frames, meta, method, progress=progress, return_sizes=True, **params)
        if frame_indices is not None:
            table["frame"] = np.asarray(frame_indices, dtype=np.int64)
        else:
            table["frame"] = table["frame"].to_numpy(dtype=np.int64) + int(meta.provenance.get("first_frame", 0))
        table = table.drop(columns=[c for c in ("method", "cohesion") if c in table])
        return cls(meta, table, [np.asarray(s, dtype=np.int64) for s in sizes], method, _identification(method, params),
                   path)

    def check_identification(self, method, params) -> None:
        """Refuse (ParameterError) comparing these statistics under another identification than
        they were made with (``method`` and ``params``, defaults filled in)."""
        wanted = _identification(method, params)
        if method != self.method or wanted != self.params:
            differ = sorted(k for k in set(wanted) | set(self.params) if wanted.get(k) != self.params.get(k))
            raise ParameterError(
                f"{self.path or 'RunStatistics'}: kept statistics of method {self.method!r} "
                f"({', '.join(f'{k}={self.params.get(k)!r}' for k in differ)}), asked for {method!r} "
                f"({', '.join(f'{k}={wanted.get(k)!r}' for k in differ)}); they cannot be identified again")

    def join(self, other: "RunStatistics") -> "RunStatistics":
        """These statistics and ``other``'s (more frames of the same run, identified alike), by
        frame; a frame in both is refused.

        The metadata is that of the side whose frames reach further (the run as it stood last: its
        cost so far, a finished run's wall time), with the provenance entries only the other side
        has (a part begun from a checkpoint does not record the settling) and without a part's
        ``first_frame``.
        """
        if other.meta.sim_config.get("params") != self.meta.sim_config.get("params"):
            raise ParameterError(f"{other.path}: statistics of another run than {self.path}")
        other.check_identification(self.method, self.params)
        both = set(self.timeseries["frame"]) & set(other.timeseries["frame"])
        if both:
            raise ParameterError(f"{other.path}: frame {min(both)} is in {self.path} already")
        table = pd.concat([self.timeseries, other.timeseries], ignore_index=True)
        order = np.argsort(table["frame"].to_numpy(), kind="stable")
        sizes = [*self.sizes, *other.sizes]
        last = lambda stats: stats.timeseries["frame"].max() if len(stats) else -1  # noqa: E731
        later, earlier = (other, self) if last(other) > last(self) else (self, other)
        meta = RunMeta.from_dict(later.meta.to_dict())
        meta.provenance = {**earlier.meta.provenance, **later.meta.provenance}
        meta.provenance.pop("first_frame", None)
        return RunStatistics(meta, table.iloc[order].reset_index(drop=True), [sizes[k] for k in order],
                             self.method, self.params, self.path)

    @property
    def unfinished(self) -> str | None:
        """Why the run was unfinished when these statistics were kept (one phrase), or None when
        nothing says so (:meth:`RunMeta.stopped_early <granalytics.RunMeta.stopped_early>`, as a run
        file's :attr:`~granalytics.core.reader.Run.unfinished` says it)."""
        last = int(self.timeseries["frame"].max()) if len(self) else -1
        return "; ".join(self.meta.stopped_early(held=f"; the statistics reach frame {last}")) or None

    def identity(self) -> dict:
        """What tells this run from another (as :func:`~granalytics.analysis.run_systems.run_identity`
        for a run file; ``content`` is a checksum of the kept statistics)."""
        from granalytics.analysis.run_systems import system_of

        digest = hashlib.sha256(pd.util.hash_pandas_object(self.timeseries, index=False).to_numpy().tobytes())
        return {"path": self.path, "alpha": self.meta.alpha, "n_particles": self.meta.n_particles,
                "seed": self.meta.sim_config.get("params", {}).get("seed"), "system": system_of(self.meta),
                "content": digest.hexdigest()}

    def tables(self) -> dict:
        """What :func:`granalytics.save` writes of the statistics, by file name: ``frames.csv`` and
        ``sizes.csv`` (DataFrames), ``meta.json`` (a dict)."""
        counts = [np.unique(s, return_counts=True) for s in self.sizes]
        sizes = pd.DataFrame({
            "frame": np.repeat(self.timeseries["frame"].to_numpy(), [len(size) for size, _ in counts]),
            "size": np.concatenate([size for size, _ in counts] or [np.zeros(0, np.int64)]),
            "count": np.concatenate([count for _, count in counts] or [np.zeros(0, np.int64)])})
        return {"frames.csv": self.timeseries, "sizes.csv": sizes,
                "meta.json": {"meta": self.meta.to_dict(), "method": self.method, "params": self.params}}

    @classmethod
    def read(cls, folder) -> "RunStatistics":
        """The statistics :func:`granalytics.save` wrote to ``folder``.

        Raises
        ------
        ParameterError
            A file missing or unreadable (naming it).
        """
        folder = os.fspath(folder)
        paths = {name: os.path.join(folder, name) for name in RUN_STATISTICS_FILES}
        try:
            with open(paths["meta.json"]) as f:
                info = json.load(f)
            table = pd.read_csv(paths["frames.csv"])
            sizes = pd.read_csv(paths["sizes.csv"])
            meta = RunMeta.from_dict(info["meta"])
            method, params = info["method"], info["params"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ParameterError(f"{folder}: not kept run statistics ({type(exc).__name__}: {exc})") from None
        by_frame = {k: np.repeat(group["size"].to_numpy(np.int64), group["count"].to_numpy(np.int64))
                    for k, group in sizes.groupby("frame")}
        return cls(meta, table, [by_frame.get(k, np.zeros(0, np.int64)) for k in table["frame"]], method, params,
                   folder)
