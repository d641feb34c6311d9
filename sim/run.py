"""Simulation driver: filling, settling, stepping, output to granalytics runs (its checkpoints
are written and read by :mod:`sim.checkpoint`).

Python runs only between kernel calls (a kernel call advances until the next output frame or
the next Verlet-list rebuild, typically hundreds of steps).
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import time as _time

import numpy as np

from granalytics.core import RunMeta, RunWriter, Snapshot, __version__
from granalytics.base.resources import check_disk, check_memory

from . import _kernels
from .capillary import pair_capillary_force
from .checkpoint import check_new_part, check_resume, checkpoint_path, remove_checkpoint, write_checkpoint
from .drum import n_walls
from .neighbours import empty_slots, rebuild
from .packing import check_settled_bed, insertion_positions, settled_bed_report
from .params import PHYSICS_VERSION, SimParams, steps_per_contact
from .state import State
from .threads import ThreadGovernor, check_threads

__all__ = ["Simulation", "check_room", "PHYSICS_VERSION"]

#: a lower bound of the stored size of one frame per particle [bytes] (positions, velocities,
#: radii, films and contacts, compressed), for refusing up front a run that cannot fit on the disk
FRAME_BYTES_PER_PARTICLE = 50
#: memory of the simulation state per particle, its slots (walls and about ten pairs) included [bytes]
STATE_BYTES_PER_PARTICLE = 4000


def _kernels_cached() -> bool:
    """Whether numba's cache holds the step kernel (``sim/__pycache__/_kernels.advance-*.nbi``)."""
    import glob

    return bool(glob.glob(os.path.join(os.path.dirname(__file__), "__pycache__", "_kernels.advance-*.nbi")))


def check_room(params, n_frames, out) -> None:
    """Refuse (``ParameterError``) a run whose state cannot fit in memory (``--particles 1e15``) or
    whose ``n_frames`` frames cannot fit on the disk of ``out`` (``--revolutions 1e12``), before
    any work."""
    check_memory(f"a simulation of {params.n_particles} particles", params.n_particles * STATE_BYTES_PER_PARTICLE)
    check_disk(f"{n_frames} frames of {params.n_particles} particles",
               n_frames * params.n_particles * FRAME_BYTES_PER_PARTICLE, out)


class Simulation:
    """A wet-DEM simulation of the baffled drum.

    Parameters
    ----------
    params : SimParams
        Parameters of this (possibly coarse-grained) system.
    original : SimParams, optional
        The α = 1 parameters this system was coarse-grained from (recorded in the run
        metadata); defaults to ``params`` when ``params.alpha == 1``.
    state : State, optional
        Start from this state (e.g. a checkpoint's, :mod:`sim.checkpoint`) instead of filling the drum.
    progress : bool, default False
        A progress bar over the settling of a new filling (``settle_time``: minutes to hours
        for the large presets).
    threads : int or "auto", optional
        Threads of the kernels (:attr:`threads`); default: numba's current count.

    Attributes
    ----------
    resume_point : sim.checkpoint.ResumePoint or None
        Where the run goes on when this simulation was restored from a run's checkpoint
        (:func:`sim.checkpoint.resume_run`); None otherwise.
    """

    _threads = None
    _governor = None
    resume_point = None

    def __init__(self, params: SimParams, original: SimParams | None = None, state: State | None = None, *,
                 progress: bool = False, threads: int | str | None = None):
        self.threads = threads
        self.params = params
        if original is None:
            if params.alpha != 1:
                raise ValueError("a coarse-grained run needs its original (alpha = 1) parameters")
            original = params
        self.original = original
        self.n_walls = n_walls(params.n_baffles)
        self.state = state if state is not None else self._fill(progress)

    # ------------------------------------------------------------------ set-up
    @classmethod
    def from_particles(cls, params: SimParams, position, radius, velocity=None, angular_velocity=None, film=None):
        """A simulation of given particles (no filling, no settling), e.g. for closed-form tests.

        Parameters
        ----------
        position : (N, 3) [m]; radius : (N,) [m]; velocity, angular_velocity : (N, 3), default 0;
        film : (N,) liquid film volumes [m³], default 0.
        """
        position = np.array(position, dtype=np.float64)
        n = len(position)
        params = dataclasses.replace(params, n_particles=n)
        sim = cls.__new__(cls)
        sim.params = sim.original = params
        sim.n_walls = n_walls(params.n_baffles)
        radius = np.array(radius, dtype=np.float64)
        sim.state = sim._new_state(position, radius)
        if velocity is not None:
            sim.state.vel[:] = velocity
        if angular_velocity is not None:
            sim.state.omega[:] = angular_velocity
        if film is not None:
            sim.state.film[:n] = film
        sim.state = rebuild(sim.state, params, sim.n_walls)
        sim.liquid_initial = sim.state.total_liquid()
        return sim

    def _new_state(self, position, radius) -> State:
        n = len(radius)
        mass = self.params.density * 4 / 3 * math.pi * radius**3
        return State(
            step=0, n_sprays=0, sprayed_total=0.0,
            ids=np.arange(n, dtype=np.int64), pos=position.copy(), vel=np.zeros((n, 3)), omega=np.zeros((n, 3)),
            radius=radius, mass=mass, inertia=0.4 * mass * radius**2, x_ref=position.copy(),
            film=np.zeros(n + self.n_walls),
            part_start=np.zeros(n + 1, dtype=np.int64), part_slots=np.zeros(0, dtype=np.int64),
            body_start=np.zeros(n + self.n_walls + 1, dtype=np.int64), body_slots=np.zeros(0, dtype=np.int64),
            **empty_slots(n, self.n_walls, 0),
        )

    def _fill(self, progress=False) -> State:
        """Insert particles without overlaps at jittered sites of a bcc lattice, lowest sites
        first, inside the drum and clear of the baffles (:func:`sim.packing.insertion_positions`);
        radii uniform in [1 − d_spread, 1 + d_spread]·r_mean from the seeded generator. Then
        settle, and refuse a planar settled bed (:func:`sim.packing.check_settled_bed`);
        the settled bed's structure is kept in ``settled_bed`` and the run metadata."""
        p = self.params
        rng = np.random.default_rng(p.seed)
        n = p.n_particles
        radius = p.r_mean * rng.uniform(1 - p.d_spread, 1 + p.d_spread, n)
        sites = insertion_positions(p, radius, rng)
        self.state = rebuild(self._new_state(sites, radius), p, self.n_walls)
        from tqdm.auto import tqdm

        settle_steps = int(round(p.settle_time / p.dt))
        first = min(settle_steps, 1)  # the first step compiles (or loads) the kernels, outside the bar's rate
        if progress and first and not _kernels_cached():
            print("compiling the simulator's kernels (the first run of this installation: about a minute; later "
                  "runs load them from numba's cache)", file=sys.stderr, flush=True)
        wall0, cpu0 = _time.perf_counter(), _time.process_time()
        self._advance(first, settling=True)
        with tqdm(total=settle_steps, initial=first, unit="step", unit_scale=True, disable=not progress,
                  desc=f"settling {n} particles α={p.alpha:g}") as bar:
            self._advance(settle_steps - first, settling=True, on_steps=bar.update)
        self.state.step = 0
        # the settling's cost, apart from the run's (a run's cpu_time_s starts at its frame 0)
        self.settle_cost = {"settle_wall_time_s": _time.perf_counter() - wall0,
                            "settle_cpu_time_s": _time.process_time() - cpu0}
        self.settled_bed = settled_bed_report(p, self.snapshot())
        check_settled_bed(self.settled_bed, p.settle_time)
        if p.bridge_volume > 0:  # the fixed-volume model: the touching pairs of the settled bed are wet
            self.state.v_b[self.state.alive] = p.bridge_volume
            if not p.wall_bridges:
                self.state.v_b[:n * self.n_walls] = 0.0
        else:
            self.state.film[:n] = p.initial_film * 4 / 3 * math.pi * self.state.radius**3
        self.liquid_initial = self.state.total_liquid()
        return self.state

    # ------------------------------------------------------------------ stepping
    @property
    def threads(self) -> int | str | None:
        """Threads of the kernels: ``None`` (numba's current count, left as it is), a count
        (set with ``numba.set_num_threads`` now), or ``"auto"``: a :class:`sim.threads.ThreadGovernor`
        chooses the count as the run goes, from the rates it measures (docs/simulator.md,
        "Threads"). Results are bit-identical for any choice.

        Raises
        ------
        ValueError
            A count outside [1, ``NUMBA_NUM_THREADS``], or another value.
        """
        return self._threads

    @threads.setter
    def threads(self, value) -> None:
        import numba

        value = check_threads(int(value) if isinstance(value, np.integer) else value)
        self._governor = ThreadGovernor() if value == "auto" else None
        if isinstance(value, int):
            numba.set_num_threads(value)
        self._threads = value

    def _advance(self, n_steps: int, settling: bool = False, on_steps=None) -> None:
        """Advance ``n_steps`` steps, rebuilding the lists whenever the kernel stops for it;
        ``on_steps(k)`` is called after each kernel call with the steps it did (e.g. a progress
        bar's update). With ``threads="auto"`` each call is capped by the governor, which sets
        the thread count before it; a call that ends at its cap is followed by no rebuild, so
        the trajectory is the same however the steps are split."""
        p, s = self.params, self.state
        kernel_params = _kernels.kernel_params(p, self.n_walls)
        governor = self._governor
        remaining = n_steps
        step = 0 if settling else s.step
        while remaining > 0:
            cap = remaining if governor is None else governor.begin(p.n_particles, remaining)
            t0 = _time.perf_counter()
            body_key = np.concatenate([s.ids, s.ids.max() + 1 + np.arange(self.n_walls)])
            done, s.n_sprays, sprayed = _kernels.advance(
                cap, step, settling, s.n_sprays, kernel_params, _kernels.kernel_arrays(s, body_key, self._bridge_table()))
            s.sprayed_total += sprayed
            if on_steps is not None:
                on_steps(done)
            remaining -= done
            step += done
            if not settling:
                s.step = step
            if done < cap:  # a particle moved more than half the skin
                self.state = s = rebuild(s, p, self.n_walls)
            if governor is not None:
                governor.end(done, p.n_particles, _time.perf_counter() - t0)

    def _check_finite(self) -> None:
        """RuntimeError when a particle's position or velocity is no longer a finite number (an
        unstable integration), naming it, before the frame or a checkpoint is written."""
        s = self.state
        bad = np.flatnonzero(~(np.isfinite(s.pos).all(axis=1) & np.isfinite(s.vel).all(axis=1)))
        if bad.size:
            raise RuntimeError(f"the simulation became unstable at step {s.step}: particle id {s.ids[bad[0]]} has "
                               f"position {s.pos[bad[0]].tolist()} m and velocity {s.vel[bad[0]].tolist()} m/s "
                               f"({bad.size} particles not finite); check Δt and the forces' parameters")

    def _bridge_table(self) -> np.ndarray:
        """The cache of bridge constants for the state's current slot list (a new one after a
        rebuild or when the state was replaced): derived data, never checkpointed."""
        slots = self.state.pair_i
        if getattr(self, "_table_slots", None) is not slots:
            self._table, self._table_slots = _kernels.new_bridge_table(slots.shape[0]), slots
        return self._table

    def advance(self, n_steps: int) -> None:
        """Advance ``n_steps`` time steps (t = step·Δt)."""
        self._advance(int(n_steps))

    @property
    def time(self) -> float:
        """Simulated time since the end of settling [s]."""
        return self.state.step * self.params.dt

    # ------------------------------------------------------------------ output
    def run_meta(self) -> RunMeta:
        """granalytics metadata of this run (CG factor and the original system included)."""
        p, o = self.params, self.original
        return RunMeta(
            surface_tension=p.surface_tension, density=p.density, drum_omega=p.drum_omega,
            n_particles=p.n_particles, mean_radius=float(self.state.radius.mean()), alpha=p.alpha,
            contact_angle=p.contact_angle, gravity=tuple(p.gravity), capillary_in_contact=p.capillary_in_contact,
            n_particles_original=o.n_particles, mean_radius_original=o.r_mean,
            sim_config={"params": p.to_dict(), "original": o.to_dict(), "n_walls": self.n_walls,
                        "steps_per_contact": steps_per_contact(p),
                        "walls": "cylinder, baffles 1..n_baffles, end plates z=0 and z=L",
                        "liquid_model": "fixed_bridge_volume" if p.bridge_volume > 0 else "films_spray_migration"},
            provenance={"code": "sim", "version": __version__, "physics_version": PHYSICS_VERSION,
                        **({"settled_bed": self.settled_bed} if getattr(self, "settled_bed", None) else {}),
                        **getattr(self, "settle_cost", {})},
        )

    def snapshot(self, meta: RunMeta | None = None) -> Snapshot:
        """The current state as a granalytics snapshot: every particle and every live
        particle–particle interaction (contact or bridge). Wall interactions are not pairs of
        particles and are left out; liquid held by walls is ``state.film[N:]``.

        ``f_cap`` is the force law of ``sim.capillary_force`` (the engine's own) at each pair's
        gap and *current* bridge volume. That is the force the last step computed, except for a
        bridge created or refilled by that step's liquid migration: the step's force pass ran
        before the migration, with the earlier volume (0 for a new bridge), and
        ``state.f_cap`` keeps that value.

        Particles are in the order of their ids and contacts in the order of their (i, j), so a
        frame does not depend on the order the simulator keeps its rows in (re-sorted along a
        space-filling curve at every neighbour-list rebuild, :func:`sim.neighbours.rebuild`).
        """
        s, p = self.state, self.params
        n = s.n_particles
        order = np.argsort(s.ids, kind="stable")
        row_of = np.empty(n, dtype=np.int64)
        row_of[order] = np.arange(n)
        live = np.flatnonzero(s.alive[n * self.n_walls:]) + n * self.n_walls
        a, b = row_of[s.pair_i[live]], row_of[s.pair_j[live]]
        i, j = np.minimum(a, b), np.maximum(a, b)
        by_pair = np.lexsort((j, i))
        live, i, j = live[by_pair], i[by_pair], j[by_pair]
        radius = s.radius[order]
        f_cap = pair_capillary_force(s.gap[live], radius[i], radius[j], s.v_b[live], p.surface_tension,
                                     p.contact_angle, p.capillary_model)
        return Snapshot(
            time=self.time, step=s.step, ids=s.ids[order], radius=radius, position=s.pos[order],
            velocity=s.vel[order], angular_velocity=s.omega[order], film_volume=s.film[:n][order],
            contact_i=i, contact_j=j, f_cap=f_cap,
            f_normal=s.f_normal[live], gap=s.gap[live], bridge_volume=s.v_b[live],
            meta=meta if meta is not None else self.run_meta(),
        )

    # ------------------------------------------------------------------ runs
    def frame_plan(self, revolutions, frame_every=None) -> tuple[int, int]:
        """``(frame_every, n_frames)`` of a run of ``revolutions`` drum revolutions.

        Frames are written every ``frame_every`` steps (default: the step count nearest to 0.05
        revolution), frame 0 at t = 0, and the last one at the requested end: ``revolutions``
        must be a whole number n of frame intervals, up to the rounding of the interval to whole
        steps (|n·frame_every − revolutions·T/Δt| ≤ (n + 1)/2 steps), and ``n_frames`` = n + 1.

        Raises
        ------
        ValueError
            ``revolutions`` not finite and > 0, a drum that does not turn, ``frame_every`` not a
            positive integer, or ``revolutions`` not a whole number of frame intervals.
        """
        p = self.params
        if not (isinstance(revolutions, (int, float, np.integer, np.floating)) and math.isfinite(revolutions)
                and revolutions > 0):
            raise ValueError(f"revolutions must be a finite number > 0, got {revolutions!r}")
        if not math.isfinite(p.revolution_period):
            raise ValueError("the drum does not turn (drum_omega = 0): a run is measured in revolutions")
        if frame_every is None:
            frame_every = max(1, int(round(0.05 * p.revolution_period / p.dt)))
        if not (isinstance(frame_every, (int, np.integer)) and not isinstance(frame_every, bool) and frame_every >= 1):
            raise ValueError(f"frame_every must be a positive whole number of steps, got {frame_every!r}")
        frame_every = int(frame_every)
        total = revolutions * p.revolution_period / p.dt  # steps, not rounded
        n = int(round(total / frame_every))
        if n < 1 or abs(n * frame_every - total) > (n + 1) / 2:
            raise ValueError(
                f"revolutions = {revolutions:g} ({total:.6g} steps) is not a whole number of frame intervals of "
                f"{frame_every} steps ({total / frame_every:.6g}); the last frame would miss the requested end")
        return frame_every, n + 1

    def run(self, out, revolutions, *, frame_every=None, checkpoint_every=20, progress=True, resume=False,
            overwrite=False, checkpoint_minutes=None, new_part=False):
        """Simulate ``revolutions`` drum revolutions, writing a frame every ``frame_every``
        steps (default: every 0.05 revolution) to the granalytics run file ``out``; see
        :meth:`frame_plan`.

        A checkpoint ``out + '.ckpt.npz'`` (:mod:`sim.checkpoint`) is written every
        ``checkpoint_every`` frames (None: never) and, with ``checkpoint_minutes``, also between
        frames once that many minutes of wall time have passed since the last one (for frames
        that take long: a stop then loses at most that much work); with ``resume=True`` a
        simulation restored from it by :func:`sim.checkpoint.resume_run` continues the run (the file keeps the frames
        written up to the checkpoint) and the trajectory is bit-identical to an uninterrupted run.
        A resume first checks that the run file and the checkpoint belong together
        (:func:`sim.checkpoint.check_resume`: parameters, frame interval, frame count, time and
        step of the checkpoint's frame) and refuses with ``ValueError``, changing nothing on disk,
        when they do not.

        Resuming a run that finished (every requested frame written and its wall time recorded)
        changes nothing: the run file is left as it is, so that a recipe can be rerun safely.

        With ``new_part=True`` a simulation restored from any run's checkpoint
        (:func:`sim.checkpoint.resume_run` of ``from_checkpoint``) continues that run in a new
        file ``out``, a **part** of the run: it holds the frames from the checkpoint's next one
        on (``provenance["first_frame"]``), and the frames before stay in the file they were
        written to. A run whose files are lost but whose checkpoint was kept (copied to another
        machine, say) goes on this way; the part's trajectory is the uninterrupted run's, bit for
        bit on one machine. A part resumes from its own checkpoint like any run.

        An existing ``out`` is replaced only with ``overwrite=True`` (``FileExistsError``
        otherwise); a new run removes a checkpoint of ``out`` left by an earlier run.
        """
        from tqdm.auto import tqdm

        p = self.params
        out = os.fspath(out)
        frame_every, n_frames = self.frame_plan(revolutions, frame_every)
        if checkpoint_every is not None and not (
                isinstance(checkpoint_every, (int, np.integer)) and not isinstance(checkpoint_every, bool)
                and checkpoint_every >= 1):
            raise ValueError(f"checkpoint_every must be a whole number of frames >= 1 (or None), got {checkpoint_every!r}")
        if checkpoint_minutes is not None and not (
                isinstance(checkpoint_minutes, (int, float, np.integer, np.floating))
                and not isinstance(checkpoint_minutes, bool) and math.isfinite(checkpoint_minutes)
                and checkpoint_minutes > 0):
            raise ValueError(f"checkpoint_minutes must be a finite number > 0 (or None), got {checkpoint_minutes!r}")
        check_room(p, n_frames, out)
        ckpt = checkpoint_path(out)
        meta = self.run_meta()
        meta.provenance["planned_frames"] = int(n_frames)  # a reader can tell a killed run from a finished one
        if resume and new_part:
            raise ValueError("resume=True continues the file out, new_part=True starts it: give one of them")
        if (resume or new_part) and self.resume_point is None:
            raise ValueError("resume=True and new_part=True need a simulation restored with "
                             "sim.checkpoint.resume_run")
        if resume:
            finished, first = check_resume(self, out, frame_every, n_frames)
            if finished:
                print(f"{out}: finished already ({n_frames} frames and the run's wall time written); "
                      "nothing to resume, the file is left as it is", file=sys.stderr)
                return out
            writer = RunWriter.continue_from(out, self.resume_point.frames - first)
            writer.update_provenance(planned_frames=int(n_frames - first))  # the resumed run may plan more frames
        else:
            if os.path.exists(out) and not overwrite:
                raise FileExistsError(f"{out}: file exists (pass overwrite=True, or --overwrite, to replace it)")
            first = check_new_part(self, frame_every, n_frames) if new_part else 0
            if first:
                meta.provenance.update(first_frame=first, planned_frames=int(n_frames - first))
            writer = RunWriter(out, meta, overwrite=overwrite)
            remove_checkpoint(out)  # an earlier run's
            if not new_part:
                writer.append(self.snapshot(meta))
            if checkpoint_every is not None or checkpoint_minutes is not None:  # the settled bed (hours at 10⁵ particles, not to be settled twice), or a part's
                # start: where it resumes from should it stop before its first frame
                write_checkpoint(self, ckpt, {"frames": first + writer.n_frames, "frame_every": frame_every,
                                              "wall_s": self.resume_point.wall_s if new_part else 0.0,
                                              "cpu_s": self.resume_point.cpu_s if new_part else 0.0})
        wall0, cpu0 = _time.perf_counter(), _time.process_time()
        steps0 = self.state.step
        # of earlier sittings (CPU time None: a sitting's simulator did not record it)
        wall_before, cpu_before = (0.0, 0.0) if self.resume_point is None else (self.resume_point.wall_s,
                                                                                self.resume_point.cpu_s)

        def elapsed():
            """Wall and CPU time of the frames so far, all sittings [s]."""
            cpu = None if cpu_before is None else cpu_before + _time.process_time() - cpu0
            return {"wall_s": wall_before + _time.perf_counter() - wall0, "cpu_s": cpu}
        def done():
            """Frames of the run written so far, this part's and those of the parts before it."""
            return first + writer.n_frames

        def progressed():
            """Frames made, in fractions: those written (frame k at step k·frame_every, the settled
            bed frame 0) and the part of the next one simulated."""
            return self.state.step / frame_every + 1

        # a run resumed part-way into a frame starts its bar there, so that the rate and the time
        # left are of the work since the resume
        bar = tqdm(total=n_frames, initial=progressed(), unit="frame", disable=not progress,
                   desc=f"{p.n_particles} particles α={p.alpha:g}",
                   bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.2f}/{total} [{elapsed}<{remaining}, "
                              "{rate_fmt}{postfix}]")
        import numba

        # with checkpoint_minutes a frame is simulated in pieces of 1/20 of it, the clock read between
        # them (the trajectory does not depend on how the steps are split)
        piece = frame_every if checkpoint_minutes is None else -(-frame_every // 20)
        between_s = math.inf if checkpoint_minutes is None else 60.0 * checkpoint_minutes
        last_checkpoint = _time.perf_counter()

        def checkpoint():
            nonlocal last_checkpoint
            writer.sync()  # the frames the checkpoint counts on disk before it
            write_checkpoint(self, ckpt, {"frames": done(), "frame_every": frame_every, **elapsed()})
            last_checkpoint = _time.perf_counter()

        with writer:
            while done() < n_frames:
                frame_t0, frame_step0 = _time.perf_counter(), self.state.step
                frame_step = done() * frame_every
                while self.state.step < frame_step:
                    self.advance(min(piece, frame_step - self.state.step))
                    bar.update(progressed() - bar.n)
                    if self.state.step < frame_step and _time.perf_counter() - last_checkpoint >= between_s:
                        self._check_finite()
                        checkpoint()  # between frames: the state at this step, the frames written so far
                frame_wall = _time.perf_counter() - frame_t0
                self._check_finite()
                writer.append(self.snapshot(meta))
                if checkpoint_every is not None and done() % checkpoint_every == 0:
                    checkpoint()
                # the rate of the frame just simulated (the machine's load changes as the run goes)
                rate = (self.state.step - frame_step0) * p.n_particles / max(frame_wall, 1e-9)
                bar.set_postfix_str(f"t={self.time:.3f} s rev={self.time / p.revolution_period:.2f} "
                                    f"{rate / 1e6:.2f}M particle-steps/s, {numba.get_num_threads()} thread(s)")
            spent = elapsed()
            wall, cpu = spent["wall_s"], spent["cpu_s"]
            writer.update_provenance(
                physics_version=PHYSICS_VERSION, wall_time_s=wall, simulated_time_s=self.time,
                wall_time_per_simulated_s=wall / max(self.time, 1e-300), cpu_time_s=cpu,
                cpu_time_per_simulated_s=None if cpu is None else cpu / max(self.time, 1e-300),
                particle_steps_per_s=(self.state.step - steps0) * p.n_particles / max(wall - wall_before, 1e-9),
                threads=numba.get_num_threads(), thread_policy="auto" if self._governor is not None else "fixed",
                cpu_count=os.cpu_count())
        bar.close()
        return out
