"""The long runs of the paper's drum: the α = 1 confinement series of its family and the paper's
CG1 itself (120 000 particles), kept outside the work tree and resumed across working periods.

Usage::

    python benchmarks/paper_drum_runs.py start [--dt-factor F]   # first thing in a working period
    python benchmarks/paper_drum_runs.py stop
    python benchmarks/paper_drum_runs.py series [--dt-factor F] [--dir ~/granalytics-runs/paper-family]
    python benchmarks/paper_drum_runs.py cg1 [--dt-factor F] [--dir ~/granalytics-runs/paper-cg1]
    python benchmarks/paper_drum_runs.py progress [--dir ~/granalytics-runs/paper-cg1]
    python benchmarks/paper_drum_runs.py subset [--dir ~/granalytics-runs/paper-family] [--window 2:4]
    python benchmarks/paper_drum_runs.py table [--dir ~/granalytics-runs/paper-family] [--window 2:4]
    python benchmarks/paper_drum_runs.py figures --out FOLDER [--dir ~/granalytics-runs/paper-family] [--window 2:4]
                                                 [--reference ~/granalytics-runs/paper-cg1/paper-cg1.h5]
                                                 [--size-unit original|particles]

``start`` starts or resumes ``cg1`` and ``series`` (below), each detached from the shell unless it
is running already, CG1 at normal priority and the series at nice 5, their output appended to
``log.txt`` beside them; ``stop`` ends both as Ctrl-C would (each simulation keeps its checkpoint).

``series`` makes, one after the other on one thread, the α = 1 runs of the paper drum's family
(``python -m sim run --preset paper-cg1 --drum-ratio D``: its aspect, fill, baffles and spray zone,
sized for D/d of the particles) at D/d 22, 33 and 44 (539, 1 819 and 4 312 particles; seeds 0-2) and
66 (14 554 particles; seed 0, then seed 1), and, interleaved with them, the paper drum's CG runs
under both rules (paper-cg3 ``weber`` and ``bond`` seeds 0-1, paper-cg2 ``weber`` seed 1 beside the
bundled seed 0, paper-cg2 ``bond`` seed 0), 4 revolutions each, the largest last; a run already
finished is skipped and an interrupted one resumes from its checkpoint. ``cg1`` starts the paper's
CG1 (``--preset paper-cg1``, its own settling, 4 revolutions, a frame every 0.05 revolution, a
checkpoint every frame and every 10 minutes between) or resumes it, on one thread beside the series
and on ``--threads auto`` once the series is done (the series, at its end, restarts a running CG1
right after its next checkpoint, so that it takes the second core). ``progress`` prints one line for
``benchmarks/paper_cg1_progress.md`` (revolutions done, CPU hours, machine). ``subset`` writes the
float32 subset of each finished run (and of CG1 once it covers the window) into ``benchmarks/paper_family_runs/`` (those there are kept).
``table`` prints the series' steady state per D/d (mean ± replica s.e.) and the confinement law y =
y∞·(1 − b/(D/d)) fitted to it, with its errors scaled by √(χ²/dof) when χ²/dof > 1, the law's value
at the paper CG1's D/d = 133 with that band, the paper drum's CG runs beside the law at their
D/(αd), and the paper's CG1 (``--cg1``) beside the law's prediction once it covers the window.
``figures`` writes the paper's Figs 3–6 for the paper drum (``ga.save`` of ``ga.compare_cg``): its
finished CG runs, one group per preset and rule (seeds as replicas), beside the largest finished α =
1 run of the family (D/d 66 once it is in), or beside ``--reference`` (the paper's CG1 once it has
the window), with the table of each against it and the speed-up from the recorded wall times (the
load-free one, also per particle-step, from the runs' checkpoints: ``benchmarks/cg_speedup.py``).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import subprocess
import sys
import warnings

import numpy as np

SERIES = [(22, 0), (22, 1), (22, 2), (33, 0), (33, 1), (33, 2), (44, 0), (44, 1), (44, 2), (66, 0), (66, 1)]
#: the paper drum's CG runs under both rules: (preset, rule, seed)
PAPER_CG = [("paper-cg3", "weber", 0), ("paper-cg3", "bond", 0), ("paper-cg3", "weber", 1), ("paper-cg3", "bond", 1),
            ("paper-cg2", "weber", 1), ("paper-cg2", "bond", 0)]
REVOLUTIONS = 4
DEFAULT_FACTOR = 1.5
LAW_METRICS = (("yield_fraction", "yield"), ("mean_volume_norm", "⟨V_g⟩/V_p"), ("n_granules_norm", "N_g/N"))
HOME_RUNS = os.path.expanduser("~/granalytics-runs")
SERIES_DIR = os.path.join(HOME_RUNS, "paper-family")
CG1_DIR = os.path.join(HOME_RUNS, "paper-cg1")
CG1_RUN = os.path.join(CG1_DIR, "paper-cg1.h5")


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cg_rules_study import finished as _finished  # noqa: E402  (a sibling script)


def _command(out, options, factor, checkpoint_every, threads="1"):
    resume = ["--resume"] if os.path.exists(f"{out}.ckpt.npz") else ["--overwrite"] if os.path.exists(out) else []
    return [sys.executable, "-m", "sim", "run", *options, "--revolutions", str(REVOLUTIONS), "--dt-factor", f"{factor:g}",
            "--threads", threads, "--checkpoint-every", str(checkpoint_every), "--out", out, *resume]


def _queue():
    """The runs of ``series`` in the order they are made: (file name, options of ``sim run``,
    frames between checkpoints). The α = 1 series and the paper drum's CG runs are interleaved, so
    that a queue stopped part-way has a little of each; D/d 66 seed 0 comes after the first CG pair
    (the law's fourth D/d and the α = 1 run beside the paper drum's Figs 3–6), the rest of the
    largest runs last."""
    alpha1 = {(ratio, seed): (f"dd{ratio}-seed{seed}.h5", ["--preset", "paper-cg1", "--drum-ratio", str(ratio),
                                                          "--seed", str(seed)]) for ratio, seed in SERIES}
    cg = {key: (f"{key[0]}-{key[1]}-seed{key[2]}.h5", ["--preset", key[0], "--cg-rule", key[1], "--seed", str(key[2])])
          for key in PAPER_CG}
    order = [alpha1[r] for r in SERIES if r[0] <= 33]
    order += [alpha1[(44, 0)], cg[PAPER_CG[0]], cg[PAPER_CG[1]], alpha1[(66, 0)], alpha1[(44, 1)], cg[PAPER_CG[2]],
              cg[PAPER_CG[3]], alpha1[(44, 2)], cg[PAPER_CG[4]], cg[PAPER_CG[5]], alpha1[(66, 1)]]
    return [(name, [*options, "--quiet"], 2 if "66" in name or "paper-cg2" in name else 4) for name, options in order]


def series(args):
    os.makedirs(args.dir, exist_ok=True)
    for name, options, checkpoint_every in _queue():
        out = os.path.join(args.dir, name)
        if _finished_run(out):
            continue
        cmd = _command(out, options, args.dt_factor, checkpoint_every)
        print(" ".join(cmd[2:]), flush=True)
        subprocess.run(cmd, check=True)
    _hand_the_core_to_cg1(args)


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

    ckpt = f"{CG1_RUN}.ckpt.npz"
    if not any(args[args.index("--threads") + 1] == "1" for args in _simulations(CG1_DIR).values()) \
            or not os.path.exists(ckpt):
        return  # no CG1 running, or on `auto` threads already
    seen, waited = os.path.getmtime(ckpt), 0
    while os.path.getmtime(ckpt) == seen and waited < 1800:
        time.sleep(5)
        waited += 5
    print("series done: CG1 restarted after its checkpoint, to take the second core", flush=True)
    _stop(["cg1"])
    while _processes(os.path.basename(__file__), "cg1") or _simulations(CG1_DIR):
        time.sleep(1)
    _start(["cg1"], args.dt_factor)


def cg1(args):
    os.makedirs(args.dir, exist_ok=True)
    out = os.path.join(args.dir, "paper-cg1.h5")
    # one thread beside the series; once it is done, `auto`: the second core while it is free, and
    # near one thread's rate under other work (a fixed 2 would crawl beside a test suite)
    threads = "auto" if _series_done() else "1"
    # a frame is half an hour of one thread: checkpoints also between frames, so a stop loses ≤ 10 min
    cmd = _command(out, ["--preset", "paper-cg1", "--checkpoint-minutes", "10"], args.dt_factor, 1, threads)
    print(" ".join(cmd[2:]), flush=True)
    started = datetime.datetime.now().isoformat(timespec="seconds")
    child = subprocess.Popen(cmd)
    while True:  # this working period's CPU time, for the progress log, kept up to date every minute
        try:  # (a machine that stops kills this process too: a line written only at the end was lost)
            code = child.wait(timeout=60)
        except subprocess.TimeoutExpired:
            code = None
        _record_cpu_seconds(args.dir, started, _cpu_seconds_of(child.pid))  # its own child's, no other's
        if code is not None:
            if code:
                raise subprocess.CalledProcessError(code, cmd)
            return


def _record_cpu_seconds(folder, started, seconds):
    """Set this working period's line (``SECONDS STARTED``) of ``cpu_seconds.txt``."""
    if not seconds:
        return
    path = os.path.join(folder, "cpu_seconds.txt")
    lines = []
    if os.path.exists(path):
        with open(path) as f:
            lines = [line for line in f if line.strip() and not line.rstrip().endswith(started)]
    lines.append(f"{seconds:.0f} {started}\n")
    with open(path + ".tmp", "w") as f:
        f.writelines(lines)
    os.replace(path + ".tmp", path)


def progress(args):
    import granalytics as ga

    out = os.path.join(args.dir, "paper-cg1.h5")
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    machine = f"{platform.node()}, {os.cpu_count()} cores"
    if not os.path.exists(out):
        print(f"| {stamp} | no run at {out} (not started here, or this machine lost it) | | {machine} |")
        return
    with ga.open_run(out, validate=False) as run:
        revolutions = float(run.revolutions[-1]) if len(run) else 0.0
        frames, params = len(run), run.meta.sim_config["params"]
    ckpt = f"{out}.ckpt.npz"
    cpu = _cpu_hours(args.dir)
    print(f"| {stamp} | {revolutions:.2f} revolutions, {frames} frames (Δt factor {params.get('dt_factor', 1):g}; "
          f"checkpoint {'at ' + datetime.datetime.fromtimestamp(os.path.getmtime(ckpt)).strftime('%H:%M') if os.path.exists(ckpt) else 'none'})"
          f"{_pace(ckpt)} | {cpu} | {machine} |")


def _pace(ckpt) -> str:
    """The run's pace so far (the checkpoint's wall time over its steps, every sitting, waiting for
    the other core included) and the wall hours it gives to 3 and 4 revolutions; "" without one."""
    import json

    if not os.path.exists(ckpt):
        return ""
    with np.load(ckpt) as data:  # the two small entries only
        info, step = json.loads(str(data["checkpoint_info"])), int(data["step"])
    wall, frame_every, params = info.get("wall_s"), info["frame_every"], info["params"]
    if not wall or step < frame_every:
        return ""
    per_frame = wall / step * frame_every
    steps_per_rev = 2 * np.pi / params["drum_omega"] / params["dt"]
    more = [(revs, (revs * steps_per_rev - step) / frame_every * per_frame / 3600) for revs in (3, 4)]
    return (f"; pace so far {per_frame / 60:.0f} min a frame: ≈ " +
            ", ".join(f"{h:.0f} h more to {revs} revolutions" for revs, h in more if h > 0))


def _cpu_hours(folder):
    """CPU hours of the CG1 run: the working periods recorded in ``cpu_seconds.txt`` (one line of
    seconds each, kept up to date every minute by :func:`cg1`; the running period's line included)."""
    path = os.path.join(folder, "cpu_seconds.txt")
    total = 0.0
    if os.path.exists(path):
        with open(path) as f:
            total = sum(float(line.split()[0]) for line in f if line.strip())
    running = _processes("sim", os.path.join(folder, "paper-cg1.h5"))
    return f"{total / 3600:.2f} CPU h" + (" (running)" if running else "")


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


def _cpu_seconds_of(pid) -> float:
    """CPU seconds of process ``pid`` (user and system; 0 once it has ended), from /proc."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


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
    """Write the float32 subset of each finished run not yet in ``SUBSETS``: every twentieth frame
    before the window, every second (D/d 22 and 33) or fourth (larger runs) inside it; and the
    paper's CG1 once it covers the window (finished or not: it may stop at 3 revolutions), four
    frames only, as a float32 frame of 120 000 particles is ~10 MB: every fortieth before the
    window (the settled bed), the window's ends and middle."""
    import granalytics as ga

    lo, hi = args.window.split(":")
    finished = [p for group in [*_finished_series(args.dir).values(), *_finished_paper_cg(args.dir).values()]
                for p in group]
    thinning = {p: ("20", "2" if os.path.basename(p).startswith(("dd22-", "dd33-")) else "4") for p in finished}
    if os.path.exists(CG1_RUN):
        with ga.open_run(CG1_RUN, validate=False) as run:
            if len(run) and float(run.revolutions[-1]) >= float(hi) - 1e-3:
                # the window's ends and middle (a frame every 0.05 revolution), the settled bed before it
                thinning[CG1_RUN] = ("40", str(round(10 * (float(hi) - float(lo)))))
    for path, (every, window_every) in thinning.items():
        out = os.path.join(SUBSETS, os.path.basename(path))
        if os.path.exists(out):
            continue
        cmd = [sys.executable, "-m", "granalytics", "subset", path, "--out", out, "--float32", "--full-window",
               f"{lo}:{hi}", "--every", every, "--window-every", window_every]
        print(" ".join(cmd[2:]), flush=True)
        subprocess.run(cmd, check=True)


def table(args):
    import granalytics as ga

    window = tuple(float(x) for x in args.window.split(":"))
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
        print(f"| {r.drum_ratio:.1f} | {r.n_particles} | {r.n_replicas} | {r.yield_fraction:.3f} ± "
              f"{r.yield_fraction_err:.3f} | {r.mean_volume_norm:.2f} ± {r.mean_volume_norm_err:.2f} | "
              f"{r.n_granules_norm:.4f} ± {r.n_granules_norm_err:.4f} | {r.coordination:.2f} | {r.bed_angle_deg:.1f} |")
    if len(t) < 3:
        print("\n(the law needs three D/d or more)")
        return
    fits = {}
    print("\nThe law's errors are scaled by √(χ²/dof) where it exceeds 1 (`fit_confinement_curve` does it).\n")
    print("| metric | y∞ | b [d] | χ²/dof | at D/d 133 (band: scaled 1σ) |")
    print("| --- | --- | --- | --- | --- |")
    for metric, label in LAW_METRICS:
        fit = fits[metric] = ga.fit_confinement_curve(t["drum_ratio"], t[metric], np.maximum(t[f"{metric}_err"], 1e-4))
        print(f"| {label} | {fit.y_inf:.3f} ± {np.sqrt(fit.covariance[0, 0]):.3f} | {fit.b:.2f} ± "
              f"{np.sqrt(fit.covariance[1, 1]):.2f} | {fit.chi2:.1f}/{fit.dof} | {float(fit(133.3)):.3f} ± "
              f"{float(fit.error(133.3)):.3f} |")
    _paper_cg_table(args, window, fits)
    _cg1_against_law(args.cg1, window, fits)


def _cg1_against_law(path, window, fits):
    """The paper's CG1 (window, block s.e.m.) beside the law's prediction at its D/d and the paper's
    "slightly above 55 %": issue 54's verdict, once the run covers the window."""
    import granalytics as ga

    if not os.path.exists(path):
        print(f"\n(no paper-cg1 run at {path})")
        return
    with ga.open_run(path, validate=False) as run:
        last = float(run.revolutions[-1]) if len(run) else 0.0
    if last < window[1] - 1e-3:
        print(f"\n(paper-cg1 has {last:.2f} revolutions, the window [{window[0]:g}, {window[1]:g}] needs "
              f"{window[1]:g}; its verdict waits)")
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = ga.confinement_table([[path]], window, labels=["paper-cg1"])
    r = next(t.itertuples(index=False))
    print(f"\n### The paper's CG1 against the α = 1 law's prediction, window [{window[0]:g}, {window[1]:g}]\n")
    print("| metric | CG1 (± block s.e.m.) | law at D/d {:.1f} | deviation | paper |".format(r.drum_ratio))
    print("| --- | --- | --- | --- | --- |")
    for metric, label in LAW_METRICS:
        fit, mean, err = fits[metric], getattr(r, metric), getattr(r, f"{metric}_err")
        law, law_err = float(fit(r.drum_ratio)), float(fit.error(r.drum_ratio))
        paper = "slightly above 0.55" if metric == "yield_fraction" else ""
        print(f"| {label} | {mean:.4g} ± {err:.2g} | {law:.4g} ± {law_err:.2g} | {100 * (mean / law - 1):+.0f} % ± "
              f"{100 * np.hypot(err / law, mean * law_err / law**2):.0f} % | {paper} |")
    print(f"\nbed angle {r.bed_angle_deg:.1f}°, coordination {r.coordination:.2f}, {r.n_particles} particles")


def _paper_cg_table(args, window, fits):
    """The paper drum's CG runs (mean ± replica s.e., one seed: block s.e.m.) beside the α = 1 law
    at their D/(αd): the scaling rule's error at equal confinement. A Bond run at α is the α = 1
    system in a drum D/α turning at Ω√α, so for it the law (measured at Ω) is not at its drum
    speed; the table says so."""
    import granalytics as ga

    groups = _finished_paper_cg(args.dir)
    if not groups:
        print("\n(no finished paper-drum CG run yet)")
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = ga.confinement_table(list(groups.values()), window, labels=list(groups))
    print(f"\n### The paper drum's CG runs against the α = 1 law at their D/(αd), window [{window[0]:g}, "
          f"{window[1]:g}]\n")
    print("| run | α | N | seeds | D/(αd) | yield | law | ⟨V_g⟩/V_p | law | N_g/N | law | bed angle [°] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in t.itertuples(index=False):
        cells = []
        for metric, _ in LAW_METRICS:
            fit, mean, err = fits[metric], getattr(r, metric), getattr(r, f"{metric}_err")
            law, law_err = float(fit(r.drum_ratio)), float(fit.error(r.drum_ratio))
            deviation = mean / law - 1
            cells += [f"{mean:.4g} ± {err:.2g}", f"{law:.4g} ± {law_err:.2g} ({100 * deviation:+.0f} % ± "
                      f"{100 * np.hypot(err / law, mean * law_err / law**2):.0f} %)"]
        print(f"| {r.label}{' (twin: Ω√α)' if 'bond' in r.label else ''} | {r.alpha:g} | {r.n_particles} | "
              f"{r.n_replicas} | {r.drum_ratio:.1f} | {' | '.join(cells)} | {r.bed_angle_deg:.1f} |")


def figures(args):
    import granalytics as ga
    from granalytics.report.tables import format_cg_table

    if args.reference:
        groups, labels = [[args.reference]], [os.path.splitext(os.path.basename(args.reference))[0]]
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
                         ("subset", "paper-family"), ("table", "paper-family"), ("figures", "paper-family"),
                         ("start", ""), ("stop", "")):
        p = sub.add_parser(name)
        p.add_argument("--dir", default=os.path.join(HOME_RUNS, folder))
        p.add_argument("--dt-factor", type=float, default=DEFAULT_FACTOR)
        p.add_argument("--window", default="2:4")
        if name == "table":
            p.add_argument("--cg1", default=CG1_RUN,
                           help="the paper's CG1 run, set beside the law's prediction once it covers the window")
        if name == "figures":
            p.add_argument("--out", required=True, help="folder of the tables and Figs 3-6")
            p.add_argument("--overwrite", action="store_true")
            p.add_argument("--size-unit", choices=("original", "particles"), default="original",
                           help="Fig 5's sizes: original-particle equivalents α³·n (the paper's unit, to "
                           "compare CG levels of one drum; default) or each run's particles (to compare "
                           "runs at equal confinement D/(αd))")
            p.add_argument("--reference", help="the α = 1 run the CG runs are compared with (default: the "
                           "family's largest finished D/d)")
    args = parser.parse_args(argv)
    {"series": series, "cg1": cg1, "progress": progress, "subset": subset, "table": table,
     "figures": figures, "start": start, "stop": stop}[args.what](args)


if __name__ == "__main__":
    main()
