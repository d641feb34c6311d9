"""Shared test helpers: small hand-built snapshots."""

import contextlib
import math
import os
import warnings

import numpy as np
import pytest
from hypothesis import settings

from granalytics import RunMeta, Snapshot
from sim.threads import configure_threading

# hypothesis: no example database in the tree (a failing case saved in .hypothesis/ made every
# later run of a clone fail), and on CI (CI=true) a fixed, derandomized profile, so that a CI run
# is reproducible; locally the examples stay random and explore more.
settings.register_profile("ci", database=None, derandomize=True)
settings.register_profile("dev", database=None)
settings.load_profile("ci" if os.environ.get("CI") == "true" else "dev")

# numba's threading layer is fixed by the first parallel kernel a process runs. The simulator's
# command line chooses OpenMP (configure_threading); a test of granalytics' parallel kernels
# that ran first would otherwise leave the default, TBB where libtbb is installed (e.g. with the
# yade package), whose parallel regions cost ~0.5 ms each: the single-particle physics tests, with
# four regions per step, then took minutes instead of seconds.
configure_threading()

#: The analyses' warnings about what a small test run cannot support (a run stopped early, a window
#: shorter than a turn or wider than the run or with a trend, a drum that confines its bed, a CG
#: rule's measured bias). Tests whose subject is something else silence them with :func:`small_run_warnings` or
#: :func:`expects_small_run_warnings`; the tests of the warnings themselves check them.
SMALL_RUN_WARNINGS = ("unfinished run", "less than one turn of the drum", r"revolutions is wider than the run",
                      "where the drum's confinement lowers", r"revolutions is not a steady state", r"CG rule \w+ at α = [\d.]+ moved the steady")


@contextlib.contextmanager
def small_run_warnings():
    """Silence :data:`SMALL_RUN_WARNINGS` inside the block (any other warning still shows)."""
    with warnings.catch_warnings():
        for text in SMALL_RUN_WARNINGS:
            warnings.filterwarnings("ignore", message=f".*{text}", category=UserWarning)
        yield


def expects_small_run_warnings(test):
    """Decorator: silence :data:`SMALL_RUN_WARNINGS` for the whole test."""
    for text in SMALL_RUN_WARNINGS:
        test = pytest.mark.filterwarnings(f"ignore:.*{text}:UserWarning")(test)
    return test


GAMMA = 0.1095  # N/m
R0 = 0.75e-3  # m


def make_meta(n_particles, alpha=1.0, **kw):
    kw.setdefault("surface_tension", GAMMA * alpha)
    kw.setdefault("density", 2500.0)
    kw.setdefault("drum_omega", 2.0)
    kw.setdefault("mean_radius", R0 * alpha)
    return RunMeta(n_particles=n_particles, alpha=alpha, **kw)


def make_snapshot(n, pairs=(), f_norm=(), *, radius=None, velocity=None, angular_velocity=None,
                  position=None, bridge_volume=None, film_volume=None, time=0.0, step=0, meta=None, ids=None):
    """A snapshot of n particles with contacts ``pairs`` carrying F_coh = f_norm·2πγR*.

    Velocities default to +x for everyone (all pairs co-moving).
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    radius = np.full(n, R0) if radius is None else np.asarray(radius, dtype=float)
    meta = meta if meta is not None else make_meta(n)
    ci, cj = pairs[:, 0], pairs[:, 1]
    r_star = 2 * radius[ci] * radius[cj] / (radius[ci] + radius[cj])
    f_norm = np.broadcast_to(np.asarray(f_norm if len(f_norm) else 1.0, dtype=float), ci.shape)
    f_cap = f_norm * 2 * math.pi * meta.surface_tension * r_star
    if velocity is None:
        velocity = np.tile([1.0, 0.0, 0.0], (n, 1))
    if angular_velocity is None:
        angular_velocity = np.tile([0.0, 0.0, 1.0], (n, 1))
    if position is None:
        position = np.column_stack([np.arange(n) * 2 * R0, np.zeros(n), np.zeros(n)])
    return Snapshot(
        time=time, step=step,
        ids=np.arange(n) if ids is None else ids,
        radius=radius, position=position,
        velocity=np.asarray(velocity, float), angular_velocity=np.asarray(angular_velocity, float),
        film_volume=np.zeros(n) if film_volume is None else film_volume,
        contact_i=ci, contact_j=cj, f_cap=f_cap, f_normal=-f_cap,
        gap=np.full(ci.shape, 1e-5),
        bridge_volume=np.full(ci.shape, 1e-12) if bridge_volume is None else bridge_volume,
        meta=meta,
    )


@pytest.fixture
def small_snapshot():
    from granalytics.datasets.synthetic import synthetic_snapshot

    return synthetic_snapshot(2000, seed=3)


def former_lab_original(n_particles):
    """The original (α = 1) parameters of the lab drum as it was sized for 10 000 particles
    (R_d = 39.7 mm, L = 0.6 R_d, r_s = 0.63 R_d), holding ``n_particles``: the system the
    simulator's reference digests and CLI tests were made with, independent of the preset."""
    from sim.params import SimParams

    bed_volume = 10_000 * math.pi * 1.5e-3**3 / 6 / 0.6
    radius = (bed_volume / (0.25 * math.pi * 0.6)) ** (1 / 3)
    return SimParams(n_particles=n_particles, drum_radius=radius, drum_length=0.6 * radius, spray_radius=0.63 * radius)


def swallow_an_interrupt_in_import(monkeypatch, module):
    """Make ``import module`` (``from module import ...``) receive a Ctrl-C that it swallows, as a
    library does with a bare ``except:`` around an optional import."""
    import builtins
    import signal
    import time

    real = builtins.__import__

    def swallowing_import(name, *args, **kwargs):
        if name == module:
            try:
                signal.raise_signal(signal.SIGINT)
                time.sleep(0.05)
            except BaseException:  # noqa: BLE001 - what a bare except around an optional import does
                pass
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", swallowing_import)

