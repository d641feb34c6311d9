"""The long runs of the paper's drum: the α = 1 confinement series of its family and the paper's
CG1 itself (120 000 particles), kept outside the work tree and resumed across working periods.

Usage::

    python benchmarks/paper_drum_runs.py start [--dt-factor F]   # first thing in a working period
    python benchmarks/paper_drum_runs.py stop
    python benchmarks/paper_drum_runs.py series [--dt-factor F] [--dir ~/granalytics-runs/paper-family]
    python benchmarks/paper_drum_runs.py cg1 [--dt-factor F] [--dir ~/granalytics-runs/paper-cg1]
    python benchmarks/paper_drum_runs.py progress [--dir ~/granalytics-runs/paper-cg1]
    python benchmarks/paper_drum_runs.py keep [--dir ~/granalytics-runs/paper-cg1]   # before each stop; commit
    python benchmarks/paper_drum_runs.py subset [--dir ~/granalytics-runs/paper-family] [--window 2:4]
    python benchmarks/paper_drum_runs.py table [--dir ~/granalytics-runs/paper-family] [--window 2:4]
    python benchmarks/paper_drum_runs.py figures --out FOLDER [--dir ~/granalytics-runs/paper-family] [--window 2:4]
                                                 [--reference RUN|benchmarks/paper_cg1_run]
                                                 [--size-unit original|particles]

``start`` starts or resumes ``cg1`` and ``series`` (below), each detached from the shell unless it
is running already, CG1 at normal priority and the series at nice 5, their output appended to
``log.txt`` beside them; ``stop`` ends both as Ctrl-C would (each simulation keeps its checkpoint).

``series`` makes, one after the other on one thread, the α = 1 runs of the paper drum's family
(``python -m sim run --preset paper-cg1 --drum-ratio D``: its aspect, fill, baffles and spray zone,
sized for D/d of the particles) at D/d 22, 33 and 44 (539, 1 819 and 4 312 particles; seeds 0-2) and
66 (14 554 particles; seed 0, and seed 1 once CG1 is done), and, interleaved with them, the paper drum's CG runs
under both rules (paper-cg3 ``weber`` and ``bond`` seeds 0-1, paper-cg2 ``weber`` seed 1 beside the
bundled seed 0, paper-cg2 ``bond`` seed 0), 4 revolutions each, the largest last; a run already
finished is skipped and an interrupted one resumes from its checkpoint. ``cg1`` starts the paper's
CG1 (``--preset paper-cg1``, its own settling, 4 revolutions, a frame every 0.05 revolution, a
checkpoint every frame and every 10 minutes between) or resumes it, on one thread beside the series
and on ``--threads auto`` once the series is done (the series, at its end, restarts a running CG1
right after its next checkpoint, so that it takes the second core). CG1 outlasts any one machine:
``keep``, before each stop, keeps in the repository (``benchmarks/paper_cg1_run/``) a compacted copy
of its newest checkpoint, the statistics of every frame that checkpoint covers and its frames at 0,
2, 3 and 4 revolutions as float32; ``cg1`` on a machine without the run (or with an older one)
goes on from the kept checkpoint in a new part, ``paper-cg1-fromNNN.h5`` (``sim run
--resume-from``). ``progress`` prints one line for ``benchmarks/paper_cg1_progress.md``
(revolutions done, pace, CPU hours of every sitting from the checkpoint, machine). ``subset``
writes the float32 subset of each finished run into ``benchmarks/paper_family_runs/`` (those there
are kept); where this machine has not a run, the series counts its subset there as finished.
``table`` prints the series' steady state per D/d (mean ± replica s.e.) and the confinement law y =
y∞·(1 − b/(D/d)) fitted to it over every D/d and from D/d 33 on, with its errors scaled by √(χ²/dof)
when χ²/dof > 1, the law's values at the paper CG1's D/d = 133 with that band (``--figure FILE``
draws it all against D/(αd)), the paper drum's CG runs beside the law at their
D/(αd), and the paper's CG1 (from its kept statistics) beside the law's prediction once they
cover the window.
``figures`` writes the paper's Figs 3–6 for the paper drum (``ga.save`` of ``ga.compare_cg``): its
finished CG runs, one group per preset and rule (seeds as replicas), beside the largest finished α =
1 run of the family (D/d 66 once it is in), or beside ``--reference``: α = 1 run files (seeds of one
system, as replicas), or the
paper's CG1 from the statistics kept of it (``benchmarks/paper_cg1_run``, ``ga.RunStatistics``), with the table of each against it and the speed-up from the recorded wall times (the
load-free one, also per particle-step, from the runs' checkpoints: ``benchmarks/cg_speedup.py``).
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import os
import platform
import shutil
import subprocess
import sys
import warnings

import numpy as np

SERIES = [(22, 0), (22, 1), (22, 2), (33, 0), (33, 1), (33, 2), (44, 0), (44, 1), (44, 2), (66, 0), (66, 1)]
#: the paper drum's CG runs under both rules: (preset, rule, seed)
PAPER_CG = [("paper-cg3", "weber", 0), ("paper-cg3", "bond", 0), ("paper-cg3", "weber", 1), ("paper-cg3", "bond", 1),
            ("paper-cg2", "weber", 1), ("paper-cg2", "bond", 0)]
REVOLUTIONS = 4
FRAME_EVERY_REV = 0.05
WINDOW = (2.0, 4.0)
DEFAULT_FACTOR = 1.5
LAW_METRICS = (("yield_fraction", "yield"), ("mean_volume_norm", "⟨V_g⟩/V_p"), ("n_granules_norm", "N_g/N"))
HOME_RUNS = os.path.expanduser("~/granalytics-runs")
SERIES_DIR = os.path.join(HOME_RUNS, "paper-family")
CG1_DIR = os.path.join(HOME_RUNS, "paper-cg1")


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cg_rules_study import finished as _finished  # noqa: E402  (a sibling script)
from sim.checkpoint import checkpoint_path  # noqa: E402


def _command(out, options, factor, checkpoint_every, threads="1"):
    resume = ["--resume"] if os.path.exists(checkpoint_path(out)) else ["--overwrite"] if os.path.exists(out) else []
    return [sys.executable, "-m", "sim", "run", *options, "--revolutions", str(REVOLUTIONS), "--dt-factor", f"{factor:g}",
            "--threads", threads, "--checkpoint-every", str(checkpoint_every), "--out", out, *resume]


def _queue():
    """The runs of ``series`` in the order they are made: (file name, options of ``sim run``,
    frames between checkpoints). The α = 1 series and the paper drum's CG runs are interleaved, so
    that a queue stopped part-way has a little of each; D/d 66 seed 0 comes after the first CG pair
    (the law's fourth D/d and the α = 1 run beside the paper drum's Figs 3–6), the paper-cg2 runs
    last, and D/d 66 seed 1 only once CG1 has run its revolutions: CG1, days long, takes the second
    core as soon as the CG runs are done."""
    alpha1 = {(ratio, seed): (f"dd{ratio}-seed{seed}.h5", ["--preset", "paper-cg1", "--drum-ratio", str(ratio),
                                                          "--seed", str(seed)]) for ratio, seed in SERIES}
    cg = {key: (f"{key[0]}-{key[1]}-seed{key[2]}.h5", ["--preset", key[0], "--cg-rule", key[1], "--seed", str(key[2])])
          for key in PAPER_CG}
    order = [alpha1[r] for r in SERIES if r[0] <= 33]
    order += [alpha1[(44, 0)], cg[PAPER_CG[0]], cg[PAPER_CG[1]], alpha1[(66, 0)], alpha1[(44, 1)], cg[PAPER_CG[2]],
              cg[PAPER_CG[3]], alpha1[(44, 2)], cg[PAPER_CG[4]], cg[PAPER_CG[5]]]
    if _cg1_done():  # until then CG1 takes the second core the series leaves
        order.append(alpha1[(66, 1)])
    return [(name, [*options, "--quiet"], 2 if "66" in name or "paper-cg2" in name else 4) for name, options in order]


def series(args):
    os.makedirs(args.dir, exist_ok=True)
    for name, options, checkpoint_every in _queue():
        out = os.path.join(args.dir, name)
        if _finished_run(out):
            continue
        stem = name[:-3]
        cmd = _run_command(args.dir, stem, options, args.dt_factor, checkpoint_every, "1",
                           _series_kept_checkpoint(stem))
        print(" ".join(cmd[2:]), flush=True)
        subprocess.run(cmd, check=True)
        _join_parts(args.dir, stem)
    _hand_the_core_to_cg1(args)


def _cg1_done() -> bool:
    """Whether the paper's CG1 has run its ``REVOLUTIONS`` (its newest checkpoint, here or kept,
    covers every frame: those of revolution 0 to ``REVOLUTIONS``, both included)."""
    newest = _newest(CG1_DIR, "paper-cg1", CG1_KEPT_CHECKPOINT)
    return newest is not None and newest[1][0] >= round(REVOLUTIONS / FRAME_EVERY_REV) + 1


def _series_done() -> bool:
    return all(_finished_run(os.path.join(SERIES_DIR, name)) for name, _, _ in _queue())


def _finished_run(path):
    """The finished run ``path`` of the series, or its committed float32 subset (``SUBSETS``) where
    this machine has not the run (a new machine: the runs outside the work tree are gone, their
    subsets are not); None if neither."""
    if _finished(path):
        return path
    kept = os.path.join(SUBSETS, os.path.basename(path))
    return kept if os.path.exists(kept) else None


def _hand_the_core_to_cg1(args):
    """Once the series is done, restart a running CG1 (one thread) right after its next checkpoint
    (at most 10 min away, so no work is lost), so that it takes the core the series leaves."""
    import time

    running = [command for command in _simulations(CG1_DIR).values()
               if command[command.index("--threads") + 1] == "1"]
    if not running:
        return  # no CG1 running, or on `auto` threads already
    ckpt = checkpoint_path(running[0][running[0].index("--out") + 1])
    if not os.path.exists(ckpt):
        return  # settling (its first checkpoint is the settled bed, an hour or more away): left alone
    seen, waited = os.path.getmtime(ckpt), 0
    while os.path.getmtime(ckpt) == seen and waited < 1800:
        time.sleep(5)
        waited += 5
    print("series done: CG1 restarted after its checkpoint, to take the second core", flush=True)
    _stop(["cg1"])
    while _processes(os.path.basename(__file__), "cg1") or _simulations(CG1_DIR):
        time.sleep(1)
    _start(["cg1"], args.dt_factor)


#: what the repository keeps of the paper's CG1, so that the run goes on when a working period
#: starts on a machine that lost ``CG1_DIR`` (benchmarks/paper_cg1_run/README.md)
CG1_KEPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "paper_cg1_run")
CG1_KEPT_CHECKPOINT = os.path.join(CG1_KEPT, "paper-cg1.ckpt.npz")
#: CG1's frames kept as float32 run files (~10 MB each): the settled bed, the window's ends and middle
CG1_KEPT_FRAMES = (0, 40, 60, 80)


def _checkpoint_point(path):
    """(frames, step, info) of checkpoint ``path`` (its two small entries only), None if missing."""
    import json

    if not os.path.exists(path):
        return None
    with np.load(path) as data:
        info = json.loads(str(data["checkpoint_info"]))
        return int(info["frames"]), int(data["step"]), info


def _parts(folder, stem) -> list:
    """The run files of run ``stem`` on this machine, [(first frame, path)] in order: ``STEM.h5``
    (from frame 0) and the parts ``STEM-fromNNN.h5`` begun from a kept checkpoint (``sim run
    --resume-from``)."""
    parts = []
    for name in os.listdir(folder) if os.path.isdir(folder) else []:
        if name == f"{stem}.h5":
            parts.append((0, os.path.join(folder, name)))
        elif name.startswith(f"{stem}-from") and name.endswith(".h5") and name[len(stem) + 5:-3].isdigit():
            parts.append((int(name[len(stem) + 5:-3]), os.path.join(folder, name)))
    return sorted(parts)


def _newest(folder, stem, kept_checkpoint):
    """(path of the newest checkpoint of run ``stem``, its point, its run file or None for the kept
    one): this machine's part whose checkpoint lies furthest on, or the repository's
    ``kept_checkpoint`` where that lies further (or this machine has none); None if neither exists."""
    best = None
    for _, path in _parts(folder, stem):
        point = _checkpoint_point(checkpoint_path(path))
        if point and (best is None or point[1] > best[1][1]):
            best = (checkpoint_path(path), point, path)
    kept = _checkpoint_point(kept_checkpoint)
    if kept and (best is None or kept[1] > best[1][1]):
        best = (kept_checkpoint, kept, None)
    return best


def _run_command(folder, stem, options, factor, checkpoint_every, threads, kept_checkpoint):
    """``sim run`` of run ``stem`` in ``folder``: a new run, this machine's newest part resumed, or,
    where the repository's kept checkpoint lies further (this machine lost the run, or has an
    older part), a new part ``STEM-fromNNN.h5`` from it."""
    newest = _newest(folder, stem, kept_checkpoint)
    if newest is None or newest[2] is not None:
        return _command(newest[2] if newest else os.path.join(folder, f"{stem}.h5"), options, factor,
                        checkpoint_every, threads)
    part = os.path.join(folder, f"{stem}-from{newest[1][0]:03d}.h5")
    cmd = [arg for arg in _command(part, options, factor, checkpoint_every, threads) if arg != "--resume"]
    return cmd + ["--resume-from", kept_checkpoint] + (["--overwrite"] if os.path.exists(part)
                                                        and "--overwrite" not in cmd else [])


def _keep_run(folder, stem, kept_checkpoint, keep_frames) -> bool:
    """Keep what a later machine needs of run ``stem``: ``keep_frames(covered)`` first (what is kept
    of the frames below ``covered``, the frame count of the newest checkpoint), then a compacted
    copy of this machine's newest checkpoint as ``kept_checkpoint`` where it lies further than the
    one kept. In that order a stop between the two leaves frames kept that a later part makes again
    (they are skipped), never a kept checkpoint past frames that were not kept. False if there is
    no checkpoint of the run, here or kept."""
    from sim.checkpoint import compact_checkpoint

    newest = _newest(folder, stem, kept_checkpoint)
    if newest is None:
        return False
    if newest[2] is None:  # the kept checkpoint is the newest: its frames only
        keep_frames(newest[1][0])
        return True
    with _snapshot(newest[0]) as snapshot:
        covered, step, _ = _checkpoint_point(snapshot)
        keep_frames(covered)
        os.makedirs(os.path.dirname(kept_checkpoint), exist_ok=True)
        size = compact_checkpoint(snapshot, kept_checkpoint)
    print(f"kept {newest[0]} (frames {covered}, step {step}) as {kept_checkpoint}: {size / 1e6:.1f} MB", flush=True)
    return True


@contextlib.contextmanager
def _snapshot(checkpoint):
    """A name for ``checkpoint`` as it is now, while the simulation goes on: a hard link (the
    simulator replaces a checkpoint by renaming a new file over it, so the link keeps the old one),
    or a copy where the file system has no links; removed afterwards. ``keep`` reads the frames a
    checkpoint covers and compacts it from the same snapshot, so a checkpoint the simulator writes
    meanwhile cannot lie past the frames kept."""
    snapshot = f"{checkpoint}.keeping"
    with contextlib.suppress(FileNotFoundError):
        os.unlink(snapshot)  # left by a keep that was stopped
    try:
        os.link(checkpoint, snapshot)
    except OSError:
        shutil.copyfile(checkpoint, snapshot)
    try:
        yield snapshot
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(snapshot)


def cg1(args):
    if _cg1_done():
        print(f"paper-cg1 has its {REVOLUTIONS:g} revolutions: nothing to run", flush=True)
        return
    os.makedirs(args.dir, exist_ok=True)
    # one thread beside the series; once it is done, `auto`: the second core while it is free, and
    # near one thread's rate under other work (a fixed 2 would crawl beside a test suite)
    threads = "auto" if _series_done() else "1"
    # a frame is half an hour of one thread: checkpoints also between frames, so a stop loses ≤ 10 min
    cmd = _run_command(args.dir, "paper-cg1", ["--preset", "paper-cg1", "--checkpoint-minutes", "10"], args.dt_factor,
                       1, threads, CG1_KEPT_CHECKPOINT)
    print(" ".join(cmd[2:]), flush=True)
    subprocess.run(cmd, check=True)


def keep(args):
    """Keep in the repository what a later machine needs of the long runs: of CG1 (``CG1_KEPT``) a
    compacted copy of its newest checkpoint, the statistics of every frame it covers
    (``frames.csv``, granule sizes in ``sizes.csv``, the run's metadata in ``meta.json``) and its
    frames of ``CG1_KEPT_FRAMES`` as float32; of the series' unfinished run (``SERIES_KEPT``) its
    compacted checkpoint and, as float32, the frames of its subset that checkpoint covers; of each
    paper-drum CG run finished here, its last checkpoint (compacted, for the load-free speed-ups).
    Run before each stop, then commit both folders."""
    def cg1_frames(covered):
        _keep_statistics(args.dir, covered)
        _keep_frames(args.dir, covered)

    if not _keep_run(args.dir, "paper-cg1", CG1_KEPT_CHECKPOINT, cg1_frames):
        print(f"no CG1 run in {args.dir} and none kept")
    for name, _, _ in _queue():
        stem = name[:-3]
        if not _parts(args.series_dir, stem):
            continue
        if not _finished_run(os.path.join(args.series_dir, name)):
            _keep_run(args.series_dir, stem, _series_kept_checkpoint(stem),
                      lambda covered, stem=stem: _keep_subset_frames(args.series_dir, stem, covered))
        elif stem.startswith("paper-cg") and not os.path.exists(_final_checkpoint(stem)):
            # a wet, sprayed bed at the run's end, for the load-free speed-ups (benchmarks/cg_speedup.py)
            _keep_run(args.series_dir, stem, _final_checkpoint(stem), lambda covered: None)


def _kept_statistics():
    """The statistics kept of CG1 so far (``ga.RunStatistics``), None before the first."""
    import granalytics as ga

    return ga.RunStatistics.read(CG1_KEPT) if os.path.exists(os.path.join(CG1_KEPT, "frames.csv")) else None


def _keep_statistics(folder, covered):
    """Add to the statistics kept of CG1 (``ga.RunStatistics`` in ``CG1_KEPT``) those of its frames
    below ``covered`` that this machine holds and they lack (GNA at the paper's thresholds, acting
    cohesion, and the bed's figures: the time series ``confinement_table`` averages)."""
    import granalytics as ga

    kept = _kept_statistics()
    done = set(kept.timeseries["frame"]) if kept else set()
    for first, path in _parts(folder, "paper-cg1"):
        with ga.open_run(path, validate=False) as run:
            wanted = [k for k in range(len(run)) if first + k < covered and first + k not in done]
            if not wanted:
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a run being written is unfinished
                new = ga.RunStatistics.of_frames([run[k] for k in wanted], run.meta, [first + k for k in wanted],
                                                 progress=True, path=CG1_KEPT)
        kept = new if kept is None else kept.join(new)
        done.update(new.timeseries["frame"])
        print(f"statistics of frames {first + wanted[0]}-{first + wanted[-1]} of {path}", flush=True)
    if kept is not None:
        ga.save(kept, CG1_KEPT, overwrite=True)


def _keep_frames(folder, covered):
    """Write the float32 copy of each frame of ``CG1_KEPT_FRAMES`` below ``covered`` that this
    machine holds and the repository lacks."""
    import granalytics as ga

    for frame in CG1_KEPT_FRAMES:
        out = os.path.join(CG1_KEPT, f"frame-{frame:03d}.h5")
        if frame >= covered or os.path.exists(out):
            continue
        for first, path in _parts(folder, "paper-cg1"):
            with ga.open_run(path, validate=False) as run:
                held = first <= frame < first + len(run)
            if held:
                os.makedirs(CG1_KEPT, exist_ok=True)
                ga.subset_run(path, out, [frame - first], float_dtype="float32")
                print(f"kept frame {frame} as {out}: {os.path.getsize(out) / 1e6:.1f} MB", flush=True)
                break


def progress(args):
    """One line for ``benchmarks/paper_cg1_progress.md``: where CG1 stands (this machine's newest
    checkpoint, or the repository's kept one), its pace and CPU time, the machine."""
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    machine = _machine()
    newest = _newest(args.dir, "paper-cg1", CG1_KEPT_CHECKPOINT)
    if newest is None:
        doing = "started, settling (no checkpoint yet)" if _simulations(args.dir) else "no CG1 run"
        print(f"| {stamp} | {doing} in {args.dir}, none kept | | {machine} |")
        return
    ckpt, (frames, step, info), run = newest
    params = info["params"]
    revolutions = step * params["dt"] * params["drum_omega"] / (2 * np.pi)
    where = (f"checkpoint at {datetime.datetime.fromtimestamp(os.path.getmtime(ckpt)).strftime('%H:%M')}"
             + (f" of {os.path.basename(run)}" if run else ", the kept one: this machine has none newer"))
    running = " (running)" if _simulations(args.dir) else ""
    cpu = info.get("cpu_s")
    print(f"| {stamp} | {revolutions:.2f} revolutions, {frames} frames (Δt factor {params.get('dt_factor', 1):g}; "
          f"{where}){_pace(info, step)} | {'' if cpu is None else f'{cpu / 3600:.2f} CPU h{running}'} | {machine} |")


def _machine() -> str:
    """This machine in words: host name, cores and, where /proc/cpuinfo names it, the CPU model (hosts
    differ between working periods, and so does the pace)."""
    model = ""
    try:
        with open("/proc/cpuinfo") as f:
            model = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "")
    except OSError:
        pass
    return f"{platform.node()}, {os.cpu_count()} cores" + (f", {model}" if model else "")


def _pace(info, step) -> str:
    """The run's pace so far (the checkpoint's wall time over its steps, every sitting, waiting for
    the other core included) and the wall hours it gives to 3 and 4 revolutions; "" without one."""
    wall, frame_every, params = info.get("wall_s"), info["frame_every"], info["params"]
    if not wall or step < frame_every:
        return ""
    per_frame = wall / step * frame_every
    steps_per_rev = 2 * np.pi / params["drum_omega"] / params["dt"]
    more = [(revs, (revs * steps_per_rev - step) / frame_every * per_frame / 3600) for revs in (3, 4)]
    return (f"; pace so far {per_frame / 60:.0f} min a frame: ≈ " +
            ", ".join(f"{h:.0f} h more to {revs} revolutions" for revs, h in more if h > 0))


def _command_lines() -> dict:
    """{pid: its command line's arguments} of the other processes, from /proc."""
    lines = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                lines[int(pid)] = f.read().decode(errors="replace").split("\0")
        except OSError:
            continue
    lines.pop(os.getpid(), None)
    return lines


def _processes(*words) -> list:
    """The ids of the other processes whose command line holds every one of ``words``: as a whole
    argument, or as its last part after a "/" (``paper_drum_runs.py`` finds
    ``benchmarks/paper_drum_runs.py``)."""
    return [pid for pid, args in _command_lines().items()
            if all(any(arg == word or arg.endswith("/" + word) for arg in args) for word in words)]


#: the long runs ``start`` keeps going: (subcommand, its folder, niceness); CG1
#: first on a core of its own, the series at a lower priority on the other
LONG_RUNS = (("cg1", CG1_DIR, 0), ("series", SERIES_DIR, 5))


def start(args):
    """Start (or resume) each long run that is not running, detached from this shell (it outlives
    it; a machine's stop ends it), its output appended to ``log.txt`` in its folder."""
    _start([what for what, _, _ in LONG_RUNS], args.dt_factor)


def _start(whats, dt_factor):
    for what, folder, niceness in LONG_RUNS:
        if what not in whats:
            continue
        if running := _processes(os.path.basename(__file__), what):
            print(f"{what}: running already (pid {', '.join(map(str, running))})")
            continue
        os.makedirs(folder, exist_ok=True)
        with open(os.path.join(folder, "log.txt"), "a") as log:
            child = subprocess.Popen([sys.executable, os.path.abspath(__file__), what, "--dt-factor", f"{dt_factor:g}"],
                                     stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                     start_new_session=True, env={**os.environ, "TQDM_MININTERVAL": "30"},
                                     preexec_fn=lambda n=niceness: os.setpriority(os.PRIO_PROCESS, 0, n))
        print(f"{what}: started (pid {child.pid}, nice {niceness}), log {folder}/log.txt")


def stop(args):
    """Stop the long runs as Ctrl-C would (SIGTERM: each simulation keeps its last checkpoint and
    releases its lock), the drivers first so that they start nothing new."""
    _stop([what for what, _, _ in LONG_RUNS])


def _simulations(folder) -> dict:
    """{pid: command line's arguments} of the simulations writing a run file in ``folder``."""
    return {pid: command for pid, command in _command_lines().items() if "sim" in command and "run" in command
            and "--out" in command[:-1] and os.path.dirname(command[command.index("--out") + 1]) == folder}


def _stop(whats):
    import signal

    drivers = [pid for what in whats for pid in _processes(os.path.basename(__file__), what)]
    sims = [pid for what, folder, _ in LONG_RUNS if what in whats for pid in _simulations(folder)]
    for pid in drivers + sims:
        try:
            os.kill(pid, signal.SIGTERM)
            print(f"stopped pid {pid}")
        except ProcessLookupError:
            pass


def _finished_series(folder) -> dict:
    """The finished α = 1 runs of the series in ``folder``, by D/d: {ratio: [paths, one per seed]}."""
    groups = {}
    for ratio, seed in SERIES:
        if path := _finished_run(os.path.join(folder, f"dd{ratio}-seed{seed}.h5")):
            groups.setdefault(ratio, []).append(path)
    return groups


def _finished_paper_cg(folder) -> dict:
    """The finished paper-drum CG runs in ``folder``: {"PRESET RULE": [paths, one per seed]}."""
    groups = {}
    for preset, rule, seed in PAPER_CG:
        if path := _finished_run(os.path.join(folder, f"{preset}-{rule}-seed{seed}.h5")):
            groups.setdefault(f"{preset} {rule}", []).append(path)
    return groups


#: the committed float32 subsets of the finished runs (benchmarks/paper_family_runs/README.md)
SUBSETS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "paper_family_runs")


def subset(args):
    """Write the float32 subset of each finished run of the series not yet in ``SUBSETS``
    (:func:`_join_parts`; the series writes each as it finishes). (CG1's frames are kept by
    ``keep``.)"""
    for name, _, _ in _queue():
        _join_parts(args.dir, name[:-3])


def _thinning(name):
    """(every, window_every) of the subset of run ``name``: every twentieth frame outside the window,
    every second (D/d 22 and 33) or fourth (larger runs) inside it."""
    return 20, 2 if name.startswith(("dd22-", "dd33-")) else 4


#: what the repository keeps of the series' unfinished run, so that it goes on on another machine
SERIES_KEPT = os.path.join(SUBSETS, "unfinished")


def _series_kept_checkpoint(stem):
    return os.path.join(SERIES_KEPT, f"{stem}.ckpt.npz")


def _final_checkpoint(stem):
    """Where ``keep`` keeps the last checkpoint of a finished paper-drum CG run (compacted), for
    ``benchmarks/cg_speedup.py`` on a later machine."""
    return os.path.join(SUBSETS, "checkpoints", f"{stem}.ckpt.npz")


def _subset_frames(stem, info) -> set:
    """The run's indices of the frames of run ``stem``'s subset (:func:`_thinning`, window
    ``WINDOW``), from a checkpoint's ``info`` (its frame interval and parameters)."""
    from granalytics.core.subset import thinned_frames

    every, window_every = _thinning(stem)
    params = info["params"]
    revolutions = (np.arange(round(REVOLUTIONS / FRAME_EVERY_REV) + 1) * info["frame_every"] * params["dt"]
                   * params["drum_omega"] / (2 * np.pi))
    return set(thinned_frames(revolutions, every, WINDOW, window_every).tolist())


def _kept_subset_files(stem) -> dict:
    """{the run's frame index: (file, its index there)} of the frames kept of run ``stem``."""
    import granalytics as ga

    held = {}
    for name in sorted(os.listdir(SERIES_KEPT)) if os.path.isdir(SERIES_KEPT) else []:
        if name.startswith(f"{stem}.f") and name.endswith(".h5"):
            path = os.path.join(SERIES_KEPT, name)
            with ga.open_run(path, validate=False) as run:
                first, kept = run.meta.provenance.get("first_frame", 0), run.meta.provenance["subset_of"]["frames_kept"]
            held.update({first + k: (path, i) for i, k in enumerate(kept)})
    return held


def _keep_subset_frames(folder, stem, covered):
    """Keep, as float32, the frames of run ``stem``'s subset below ``covered`` that this machine
    holds and the repository lacks (``SERIES_KEPT/STEM.fAAA-BBB.h5``, one file per keep)."""
    import granalytics as ga

    info = _newest(folder, stem, _series_kept_checkpoint(stem))[1][2]
    kept = _kept_subset_files(stem)
    wanted = sorted(k for k in _subset_frames(stem, info) if k < covered and k not in kept)
    for first, path in _parts(folder, stem):
        with ga.open_run(path, validate=False) as run:
            local = [k - first for k in wanted if first <= k < first + len(run)]
        if local:
            os.makedirs(SERIES_KEPT, exist_ok=True)
            out = os.path.join(SERIES_KEPT, f"{stem}.f{first + local[0]:03d}-{first + local[-1]:03d}.h5")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a run being written is unfinished
                ga.subset_run(path, out, local, float_dtype="float32")
            print(f"kept {len(local)} frames of {path} as {out}", flush=True)


def _join_parts(folder, stem):
    """Once run ``stem`` has finished here, write its float32 subset to ``SUBSETS`` (the frames of
    :func:`_subset_frames`: every twentieth before the window, every second or fourth inside it),
    then remove what ``keep`` kept of it. A run made in one piece gives its frames; a run made in
    parts, the frames kept of it (``SERIES_KEPT``) and this machine's parts. Where a frame is
    neither, nothing is written and nothing removed."""
    import granalytics as ga
    from granalytics import RunMeta, RunWriter
    from granalytics.core.subset import replacing_run

    parts = _parts(folder, stem)
    if not parts or not _finished(parts[-1][1]):
        return
    out = os.path.join(SUBSETS, f"{stem}.h5")
    if os.path.exists(out):
        _forget_kept(stem)
        return
    info = _checkpoint_point(checkpoint_path(parts[-1][1]))[2]
    frames = sorted(_subset_frames(stem, info))
    if parts[-1][0] == 0:  # made in one piece here
        os.makedirs(SUBSETS, exist_ok=True)
        ga.subset_run(parts[-1][1], out, frames, float_dtype="float32")
        _forget_kept(stem)
        print(f"{stem}: its subset of {len(frames)} frames written to {out}", flush=True)
        return
    sources = _kept_subset_files(stem)
    for first, path in parts:
        with ga.open_run(path, validate=False) as run:
            sources.update({first + k: (path, k) for k in range(len(run))})
    missing = [k for k in frames if k not in sources]
    if missing:
        print(f"{stem}: cannot write its subset, frames {missing} were neither kept nor made here", flush=True)
        return
    with ga.open_run(parts[-1][1]) as last, ga.open_run(sources[frames[0]][0], validate=False) as earliest:
        meta = RunMeta.from_dict(last.meta.to_dict())
        meta.provenance = {**earliest.meta.provenance, **meta.provenance}  # the settling, which a part lacks
    meta.provenance.pop("first_frame", None)
    meta.provenance.update(planned_frames=len(frames), subset_of={
        "file": f"{stem}.h5, made in parts ({', '.join(os.path.basename(p) for _, p in parts)} and earlier)",
        "frames_in_source": round(REVOLUTIONS / FRAME_EVERY_REV) + 1, "frames_kept": frames, "float_dtype": "float32"})
    with replacing_run(out) as tmp, RunWriter(tmp, meta, float_dtype="float32", overwrite=True) as writer:
        for k in frames:
            path, index = sources[k]
            with ga.open_run(path) as run:
                writer.append(run[index])
    _forget_kept(stem)
    print(f"{stem}: made in parts, its subset of {len(frames)} frames written to {out}", flush=True)


def _forget_kept(stem):
    """Remove what ``keep`` kept of the series run ``stem`` (it has finished)."""
    for name in os.listdir(SERIES_KEPT) if os.path.isdir(SERIES_KEPT) else []:
        if name.startswith((f"{stem}.f", f"{stem}.ckpt")):
            os.unlink(os.path.join(SERIES_KEPT, name))


def table(args):
    import granalytics as ga

    window = tuple(float(x) for x in args.window.split(":"))
    if args.figure and os.path.exists(args.figure) and not args.overwrite:
        sys.exit(f"{args.figure}: exists; pass --overwrite to replace it")
    groups = _finished_series(args.dir)
    if not groups:
        print(f"no finished run in {args.dir}")
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = ga.confinement_table(list(groups.values()), window, labels=[f"D/d {r}" for r in groups])
    print(f"\n### α = 1, paper drum family, window [{window[0]:g}, {window[1]:g}] (mean ± replica s.e.; one seed: "
          "block s.e.m.)\n")
    print("| D/d | N | seeds | yield | ⟨V_g⟩/V_p | N_g/N | coordination | bed angle [°] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in t.itertuples(index=False):
        print(f"| {r.drum_ratio:.1f} | {r.n_particles} | {r.n_replicas} | {r.yield_fraction:.4f} ± "
              f"{r.yield_fraction_err:.4f} | {r.mean_volume_norm:.2f} ± {r.mean_volume_norm_err:.2f} | "
              f"{r.n_granules_norm:.4f} ± {r.n_granules_norm_err:.4f} | {r.coordination:.2f} | {r.bed_angle_deg:.1f} |")
    if len(t) < 3:
        print("\n(the law needs three D/d or more)")
        return
    laws = _fit_laws(t)
    print("\nEach point weighs by the larger of its replica s.e. and its block s.e.m. (a few seeds may agree by "
          "chance far better than their frames scatter); the law's errors are scaled by √(χ²/dof) where it "
          "exceeds 1 (`fit_confinement_curve` does it). The law is fitted over every D/d and from D/d "
          f"{LAW_RANGES[1][1]:g} on (the most confined drum may lie off it).\n")
    print("| D/d fitted | metric | y∞ | b [d] | χ²/dof | at D/d 133 (band: scaled 1σ) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, fits in laws.items():
        for metric, label in LAW_METRICS:
            fit = fits[metric]
            print(f"| {name} | {label} | {fit.y_inf:.3f} ± {np.sqrt(fit.covariance[0, 0]):.3f} | {fit.b:.2f} ± "
                  f"{np.sqrt(fit.covariance[1, 1]):.2f} | {fit.chi2:.1f}/{fit.dof} | "
                  f"{float(fit(PAPER_DRUM_RATIO)):.3f} ± {float(fit.error(PAPER_DRUM_RATIO)):.3f} |")
    predicted = [f"{label} {low:.3g}–{high:.3g} ± {band:.1g}"
                 for (low, high, band), (_, label) in zip((_prediction(laws, m) for m, _ in LAW_METRICS), LAW_METRICS)]
    print(f"\nPredicted for the paper's CG1 (D/d 133): {'; '.join(predicted)} (the fits' values; the band the "
          "widest fit's)")
    fits, logs = laws["all"], _fit_logs(t)
    print("\nA curve that does not saturate, y = a + c·ln(D/d) (`fit_logarithmic_curve`), over every D/d: the "
          "law's form is what carries it from D/d 66 to 133\n")
    print("| metric | a | c | χ²/dof | at D/d 133 (scaled 1σ) | the law's χ²/dof (every D/d) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for metric, label in LAW_METRICS:
        log, law = logs[metric], fits[metric]
        print(f"| {label} | {log.a:.4g} | {log.c:.4g} | {log.chi2:.1f}/{log.dof} | {float(log(PAPER_DRUM_RATIO)):.3f} ± "
              f"{float(log.error(PAPER_DRUM_RATIO)):.3f} | {law.chi2:.1f}/{law.dof} |")
    _check_rule(fits["yield_fraction"])
    cg_groups = _finished_paper_cg(args.dir)
    cg_table = _paper_cg_table(cg_groups, window, fits)
    _cost_table({**{f"α = 1, D/d {r}": g for r, g in groups.items()}, **cg_groups})
    cg1 = _cg1_against_law(window, fits, logs)
    if args.figure:
        _law_figure(t, laws, logs, cg_table, cg1, args.figure)
        print(f"\nwrote {args.figure}")


#: the paper's CG1: D/d = 133 (its 1.5 mm particles in its 0.2 m drum)
PAPER_DRUM_RATIO = 133.3
#: the law is fitted over every D/d of the series, and from D/d 33 on: D/d 22, the most confined
#: drum (its bed at 62°), lies off the curve the others follow
LAW_RANGES = (("all", 0.0), ("from 33", 33.0))


def _fit_laws(t) -> dict:
    """The law fitted to ``confinement_table`` rows ``t`` over each range of :data:`LAW_RANGES` that
    has three D/d or more and other D/d than the ranges before it: {range: {metric: ConfinementFit}}."""
    import granalytics as ga

    laws, fitted = {}, []
    for name, lowest in LAW_RANGES:
        part = t[t["drum_ratio"] >= lowest]
        if len(part) >= 3 and len(part) not in fitted:  # ranges are nested: equal counts, equal points
            fitted.append(len(part))
            laws[name] = {metric: ga.fit_confinement_curve(part["drum_ratio"], part[metric], _law_errors(part, metric))
                          for metric, _ in LAW_METRICS}
    return laws


def _fit_logs(t) -> dict:
    """The non-saturating curve a + c·ln(D/d) fitted to every row of ``t``: {metric: LogarithmicFit}."""
    import granalytics as ga

    return {metric: ga.fit_logarithmic_curve(t["drum_ratio"], t[metric], _law_errors(t, metric))
            for metric, _ in LAW_METRICS}


def _check_rule(fit):
    """Print where the law over every D/d puts the yield within 10 % and 5 % of y∞, and whether
    ``CONFINEMENT_RULE['paper drum']`` (what `granalytics info` and `compare-cg` warn by) holds it."""
    import granalytics as ga

    kept = ga.CONFINEMENT_RULE["paper drum"]
    cells, rule = [], fit.rule()
    for key, fraction in (("within_10pc", 0.10), ("within_5pc", 0.05)):
        x, err = fit.within(fraction)
        agrees = kept[key] == rule[key]
        cells.append(f"within {100 * fraction:.0f} % above D/d {x:.0f} ± {err:.0f} (CONFINEMENT_RULE['paper drum'] "
                     f"{kept[key][0]:.0f} ± {kept[key][1]:.0f}: {'agrees' if agrees else 'DIFFERS'})")
    print(f"\nThe yield by the law over every D/d: {'; '.join(cells)}")


def _prediction(laws, metric, drum_ratio=PAPER_DRUM_RATIO):
    """(lowest, highest, band) of the fits' values of ``metric`` at ``drum_ratio``; the band is the
    largest of their (χ²-scaled) errors."""
    values = [float(fits[metric](drum_ratio)) for fits in laws.values()]
    return min(values), max(values), max(float(fits[metric].error(drum_ratio)) for fits in laws.values())


#: the marker of each CG level in the law's figure (its rule is the colour)
CG_MARKERS = {2.0: "D", 3.0: "s"}


def _law_figure(t, laws, logs, cg_table, cg1, path):
    """Yield, ⟨V_g⟩/V_p and N_g/N against D/(αd): the α = 1 series (± the errors the law weighs them
    by), each fit of the law with its scaled 1σ band carried to the paper's CG1 at D/d 133, the
    non-saturating curve (``logs``, :func:`_fit_logs`) dashed, the
    paper drum's CG runs at their D/(αd) (``cg_table``, a ``confinement_table``, or None), the
    paper's CG1 once measured (``cg1``: (D/d, steady state) or None) and the paper's "slightly
    above 55 %". Written atomically (``table`` refuses an existing file without ``--overwrite``)."""
    import matplotlib.pyplot as plt

    from granalytics.base.files import write_atomically

    fig, axes = plt.subplots(1, 3, figsize=(14, 5.2), layout="constrained")
    x = np.geomspace(18, 150, 200)
    for ax, (metric, label) in zip(axes, LAW_METRICS):
        ax.errorbar(t["drum_ratio"], t[metric], yerr=_law_errors(t, metric), fmt="o", color="k", capsize=3,
                    label="α = 1, paper drum's family (seeds: replica s.e. or block s.e.m.)")
        for (name, fits), colour in zip(laws.items(), ("C0", "C1")):
            fit = fits[metric]
            fitted = "every D/d" if name == "all" else f"D/d {name}"
            ax.plot(x, fit(x), color=colour, lw=1,
                    label=f"law y∞·(1 − b/(D/d)), {fitted}: χ²/dof {fit.chi2:.1f}/{fit.dof}")
            ax.fill_between(x, fit(x) - fit.error(x), fit(x) + fit.error(x), color=colour, alpha=0.15, lw=0)
        log = logs[metric]
        ax.plot(x, log(x), color="0.4", lw=1, ls="--",
                label=f"no saturation, a + c·ln(D/d), every D/d: χ²/dof {log.chi2:.1f}/{log.dof}")
        if cg_table is not None:
            errors = _law_errors(cg_table, metric)
            for k, r in enumerate(cg_table.itertuples(index=False)):
                bond = "bond" in r.label  # the rule by colour (Bond hollow), the level by marker
                ax.errorbar(r.drum_ratio, getattr(r, metric), yerr=errors.iloc[k], fmt=CG_MARKERS.get(r.alpha, "o"),
                            mfc="none" if bond else None, color="C3" if bond else "C2", capsize=3,
                            label=f"{r.label} ({r.n_replicas} seed{'s' if r.n_replicas > 1 else ''}) at D/(αd)")
        if cg1 is not None:
            drum_ratio, steady = cg1
            ax.errorbar(drum_ratio, steady.loc[metric, "mean"], yerr=steady.loc[metric, "sem"], fmt="*", ms=12,
                        color="C4", capsize=3, label="paper-cg1 (block s.e.m.)")
        if metric == "yield_fraction":
            ax.plot([PAPER_DRUM_RATIO], [0.55], marker="_", ms=20, mew=2, color="C5", ls="none",
                    label="the paper's CG1: \"slightly above 55 %\"")
        ax.axvline(PAPER_DRUM_RATIO, color="0.7", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_xticks([22, 33, 44, 66, PAPER_DRUM_RATIO], ["22", "33", "44", "66", "133"])
        ax.minorticks_off()
        ax.set_xlabel("D/(αd): drum diameter over simulated particle diameter")
        ax.set_ylabel(label)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=8)
    write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=120, format=os.path.splitext(path)[1][1:] or "png"))
    plt.close(fig)


def _law_errors(t, metric):
    """The errors the law weighs ``confinement_table`` row's ``metric`` by: the larger of the replica
    s.e. and the block s.e.m., so that two seeds that agree by chance do not pin the fit."""
    return np.fmax(t[f"{metric}_err"], t[f"{metric}_block_sem"])  # one NaN (too few blocks): the other


def _deviation(mean, err, law, law_err) -> str:
    """``mean``'s deviation from the law's value ``law`` in per cent, ± its standard error from both
    errors (``+4 % ± 1 %``)."""
    return f"{100 * (mean / law - 1):+.0f} % ± {100 * np.hypot(err / law, mean * law_err / law**2):.0f} %"


def _cg1_against_law(window, fits, logs):
    """The paper's CG1 (window, block s.e.m., from the statistics ``keep`` kept of every frame)
    beside the predictions at its D/d of the law (``fits``) and of the curve without saturation
    (``logs``), and the paper's "slightly above 55 %": which curve holds, once the run covers the
    window. Returns (its D/d, its steady state), or None before."""
    from granalytics.analysis.confinement import BED_COLUMNS, confinement_of_run
    from granalytics.analysis.metrics import HEADLINE
    from granalytics.analysis.stats import steady_state

    kept = _kept_statistics()
    last = float(kept.timeseries["revolutions"].max()) if kept else 0.0
    if last < window[1] - 1e-3:
        print(f"\n(paper-cg1 has {last:.2f} revolutions kept, the window [{window[0]:g}, {window[1]:g}] needs "
              f"{window[1]:g}; its verdict waits)")
        return None
    meta = kept.meta
    drum_ratio = confinement_of_run(meta).drum_ratio
    steady = steady_state(kept.timeseries, window, columns=(*HEADLINE, *BED_COLUMNS), source="paper-cg1")
    print(f"\n### The paper's CG1 against the α = 1 law's prediction, window [{window[0]:g}, {window[1]:g}]\n")
    print(f"| metric | CG1 (± block s.e.m.) | law at D/d {drum_ratio:.1f} | deviation | no saturation | deviation "
          "| paper |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for metric, label in LAW_METRICS:
        mean, err = steady.loc[metric, "mean"], steady.loc[metric, "sem"]
        cells = []
        for curve in (fits[metric], logs[metric]):
            value, value_err = float(curve(drum_ratio)), float(curve.error(drum_ratio))
            cells += [f"{value:.4g} ± {value_err:.2g}", _deviation(mean, err, value, value_err)]
        paper = "slightly above 0.55" if metric == "yield_fraction" else ""
        print(f"| {label} | {mean:.4g} ± {err:.2g} | {' | '.join(cells)} | {paper} |")
    print(f"\nbed angle {steady.loc['bed_angle_deg', 'mean']:.1f}°, coordination "
          f"{steady.loc['coordination', 'mean']:.2f}, {meta.n_particles} particles, "
          f"{int(steady.loc['yield_fraction', 'n_frames'])} frames")
    return drum_ratio, steady


def _paper_cg_table(groups, window, fits):
    """The paper drum's finished CG runs (``groups``, :func:`_finished_paper_cg`; mean ± the larger
    of replica s.e. and block s.e.m.) beside the α = 1 law
    at their D/(αd): the scaling rule's error at equal confinement. A Bond run at α is the α = 1
    system in a drum D/α turning at Ω√α, so for it the law (measured at Ω) is not at its drum
    speed; the table says so. Returns their ``confinement_table`` (None without runs)."""
    import granalytics as ga
    from granalytics.report.tables import plus_minus

    if not groups:
        print("\n(no finished paper-drum CG run yet)")
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = ga.confinement_table(list(groups.values()), window, labels=list(groups))
    print(f"\n### The paper drum's CG runs against the α = 1 law at their D/(αd), window [{window[0]:g}, "
          f"{window[1]:g}] (± the larger of replica s.e. and block s.e.m., as the law weighs its points)\n")
    print("| run | α | N | seeds | D/(αd) | yield | law | ⟨V_g⟩/V_p | law | N_g/N | law | bed angle [°] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    errors = {metric: _law_errors(t, metric) for metric, _ in LAW_METRICS}
    for k, r in enumerate(t.itertuples(index=False)):
        cells = []
        for metric, _ in LAW_METRICS:
            fit, mean, err = fits[metric], getattr(r, metric), errors[metric].iloc[k]
            law, law_err = float(fit(r.drum_ratio)), float(fit.error(r.drum_ratio))
            cells += [plus_minus(mean, err), f"{plus_minus(law, law_err)} ({_deviation(mean, err, law, law_err)})"]
        print(f"| {r.label}{' (twin: Ω√α)' if 'bond' in r.label else ''} | {r.alpha:g} | {r.n_particles} | "
              f"{r.n_replicas} | {r.drum_ratio:.1f} | {' | '.join(cells)} | {r.bed_angle_deg:.1f} |")
    return t


def _cost_table(runs):
    """What each finished run (``runs``: {label: paths}) cost: CPU seconds per simulated second (of
    the rotating drum, the settling apart) as its simulator recorded them, per particle, and CG1's cost over it (CG1's
    rate from its newest checkpoint, so far). Runs made before the simulator recorded CPU time are
    left out. The series' runs are made on one thread beside CG1; CG1 on one thread beside them,
    then on ``auto`` threads once the series is done, its CPU time summed over its threads: the
    ratio compares the CPU time each run took, not wall times."""
    import granalytics as ga

    rows = []
    for label, paths in runs.items():
        rates = []
        for path in paths:
            with ga.open_run(path, validate=False) as run:
                n, rate = run.meta.n_particles, run.meta.provenance.get("cpu_time_per_simulated_s")
            if rate:
                rates.append(rate)
        if rates:
            rows.append((label, n, f"{len(rates)} of {len(paths)}", float(np.mean(rates))))
    newest = _newest(CG1_DIR, "paper-cg1", CG1_KEPT_CHECKPOINT)
    cg1 = None
    if newest and newest[1][1] > 0 and newest[1][2].get("cpu_s"):
        _, (_, step, info), _ = newest
        cg1 = info["cpu_s"] / (step * info["params"]["dt"])
        rows.insert(0, ("paper-cg1 (so far)", info["params"]["n_particles"], "1 of 1", cg1))
    if not rows:
        return
    print("\n### Cost: CPU seconds per simulated second, one thread beside another run (as recorded)\n")
    print("| run | N | runs with a CPU record | CPU s per simulated s | per particle [ms] | paper-cg1 over it |")
    print("| --- | --- | --- | --- | --- | --- |")
    for label, n, counted, rate in rows:
        over = f"{cg1 / rate:.1f}×" if cg1 else "(no CG1 checkpoint)"
        print(f"| {label} | {n} | {counted} | {rate:.0f} | {1e3 * rate / n:.1f} | {over} |")


def figures(args):
    import granalytics as ga
    from granalytics.report.tables import format_cg_table

    if args.reference:  # run files (seeds of one system), or statistics kept in place of one (CG1's: CG1_KEPT)
        reference = [ga.RunStatistics.read(p) if os.path.isdir(p) else p for p in args.reference]
        first = args.reference[0]
        name = "paper-cg1" if os.path.isdir(first) else os.path.splitext(os.path.basename(first))[0]
        label = name if len(reference) == 1 else f"{name.split('-seed')[0]}, {len(reference)} seeds"
        groups, labels = [reference], [label]
    else:
        done = _finished_series(args.dir)
        if not done:
            print(f"no finished α = 1 run in {args.dir}")
            return
        ratio = max(done)
        groups, labels = [done[ratio]], [f"α=1 D/d {ratio}"]
    members = _finished_paper_cg(args.dir)
    groups += list(members.values())
    labels += list(members)
    if len(groups) < 2:
        print("no finished paper-drum CG run yet")
        return
    window = tuple(float(x) for x in args.window.split(":"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the runs are of different drums (D/d) by design: mixed systems
        comparison = ga.compare_cg(groups, labels, window=window, mixed_systems=True)
    written = ga.save(comparison, args.out, overwrite=args.overwrite, size_unit=args.size_unit)
    print(f"wrote {len(written)} files to {args.out}")
    print(format_cg_table(comparison))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    for name, folder in (("series", "paper-family"), ("cg1", "paper-cg1"), ("progress", "paper-cg1"),
                         ("keep", "paper-cg1"), ("subset", "paper-family"), ("table", "paper-family"), ("figures", "paper-family"),
                         ("start", ""), ("stop", "")):
        p = sub.add_parser(name)
        p.add_argument("--dir", default=os.path.join(HOME_RUNS, folder))
        if name == "keep":
            p.add_argument("--series-dir", default=SERIES_DIR)
        p.add_argument("--dt-factor", type=float, default=DEFAULT_FACTOR)
        p.add_argument("--window", default="2:4")
        if name == "table":
            p.add_argument("--figure", help="also draw the law, the CG runs and CG1 against D/(αd) into this "
                           "file (PNG or PDF)")
        if name in ("table", "figures"):
            p.add_argument("--overwrite", action="store_true")
        if name == "figures":
            p.add_argument("--out", required=True, help="folder of the tables and Figs 3-6")
            p.add_argument("--size-unit", choices=("original", "particles"), default="original",
                           help="Fig 5's sizes: original-particle equivalents α³·n (the paper's unit, to "
                           "compare CG levels of one drum; default) or each run's particles (to compare "
                           "runs at equal confinement D/(αd))")
            p.add_argument("--reference", nargs="+", help="the α = 1 run the CG runs are compared with: run "
                           "files (several: seeds of one system, compared as replicas) or statistics kept in place "
                           "of one (the paper's CG1: benchmarks/paper_cg1_run; default: the family's largest "
                           "finished D/d)")
    args = parser.parse_args(argv)
    {"series": series, "cg1": cg1, "progress": progress, "keep": keep, "subset": subset, "table": table,
     "figures": figures, "start": start, "stop": stop}[args.what](args)


if __name__ == "__main__":
    main()
