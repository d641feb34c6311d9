"""Outputs of the analyses and commands that are more than one file: an output folder made for
the work and removed again when it fails (:func:`output_folder`), several files that change
together or not at all (:func:`staged_outputs`), a finished folder put in the place of an earlier
one (:func:`swap_folder`), the files of a folder refused before the work when they exist
(:func:`new_output_paths`). One file alone is written with
:func:`granalytics.base.files.replaced_atomically`."""

from __future__ import annotations

import contextlib
import os

from granalytics.base.errors import ParameterError
from granalytics.base.files import check_replaceable
from granalytics.base.interrupts import interrupts_held, raise_dropped_interrupt

__all__ = ["staged_outputs", "swap_folder", "output_folder", "new_output_paths"]


def new_output_paths(folder, names, *, overwrite=False) -> list:
    """The paths of the files ``names`` in ``folder``; refuses (``ParameterError``) a ``folder``
    that is a file, and files that exist unless ``overwrite`` (before the work that writes them)."""
    folder = os.fspath(folder)
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise ParameterError(f"{folder}: exists and is not a folder")
    paths = [os.path.join(folder, name) for name in names]
    existing = [p for p in paths if os.path.exists(p)]
    if existing and not overwrite:
        raise ParameterError(f"{existing[0]}: exists (pass overwrite / --overwrite to replace {len(existing)} "
                             "existing output file(s))")
    return paths


@contextlib.contextmanager
def staged_outputs(folder=None):
    """Several output files written as one: they all change together, or none does.

    Yields a function ``stage(target) -> path`` that gives, for each output file ``target``, a
    temporary name to write into, in a staging folder ``.staging-PID-…`` inside ``folder`` (or,
    when ``folder`` is None, in the target's own folder: renames never cross file systems); the
    file's extension is kept, for writers that choose the format by it. When the block succeeds
    the staged files are swapped in by :func:`_swap_in` (every earlier target set aside first and
    put back if any rename fails; Ctrl-C held off until the swap is done or undone); when the
    block fails or is interrupted the staging folder is deleted and no target is touched.
    """
    import shutil
    import tempfile

    staging, dirs = {}, {}  # target -> staged file; base folder -> its staging folder

    def stage(target):
        target = os.fspath(target)
        check_replaceable(target)
        base = folder if folder is not None else os.path.dirname(os.path.abspath(target))
        if base not in dirs:
            dirs[base] = tempfile.mkdtemp(prefix=f".staging-{os.getpid()}-", dir=base)
        tmp = os.path.join(dirs[base], f"{len(staging):04d}-{os.path.basename(target)}")
        staging[target] = tmp
        return tmp

    try:
        yield stage
        _swap_in(staging)
    finally:
        for staging_dir in dirs.values():
            shutil.rmtree(staging_dir, ignore_errors=True)


def _swap_in(staging) -> None:
    """Rename each staged file over its target as one change: an existing target is first moved
    beside its staged file (``….old``), and if any rename fails (or Ctrl-C arrives during the
    swap) every target done so far is put back as it was and the error (the interrupt) raised."""
    done = []  # (target, where its earlier version was set aside, or None if it had none)
    raise_dropped_interrupt()
    with interrupts_held() as held:
        try:
            for target, tmp in staging.items():
                old = None
                if os.path.lexists(target):
                    old = tmp + ".old"
                    os.replace(target, old)
                done.append((target, old))
                os.replace(tmp, target)
            if held:
                raise KeyboardInterrupt
        except BaseException:
            for target, old in reversed(done):
                with contextlib.suppress(OSError):
                    if old is not None:
                        os.replace(old, target)
                    elif os.path.lexists(target):
                        os.unlink(target)
            raise


def swap_folder(new, dst) -> None:
    """Put the finished folder ``new`` in the place of ``dst`` (a folder or nothing) as one
    change: ``dst`` is renamed aside, ``new`` renamed to ``dst``, and only then the old one
    deleted. Ctrl-C is held off during the renames; if the second fails, or Ctrl-C arrived
    meanwhile, both are undone (``dst`` as it was, ``new`` still at its place) and the error (the
    interrupt) raised. ``new`` must be on the file system of ``dst`` (made beside it)."""
    import shutil

    new, dst = os.fspath(new), os.fspath(dst)
    aside = f"{dst}.old-{os.getpid()}" if os.path.lexists(dst) else None
    raise_dropped_interrupt()
    with interrupts_held() as held:
        if aside is not None:
            os.replace(dst, aside)
        try:
            os.replace(new, dst)
            if held:
                os.replace(dst, new)
                raise KeyboardInterrupt
        except BaseException:
            if aside is not None:
                os.replace(aside, dst)
            raise
    if aside is not None:
        shutil.rmtree(aside, ignore_errors=True)


@contextlib.contextmanager
def output_folder(path):
    """Make the output folder ``path`` (refusing a file of that name, naming the reason); when the
    block fails or is interrupted and the folder was made here and is empty, remove it again."""
    path = os.fspath(path)
    if os.path.exists(path) and not os.path.isdir(path):
        raise ParameterError(f"{path}: exists and is not a folder")
    created = not os.path.exists(path)
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        raise ParameterError(f"{path}: cannot create the output folder ({exc.strerror or exc})") from None
    try:
        yield path
    except BaseException:
        if created:
            with contextlib.suppress(OSError):
                os.rmdir(path)  # only if empty
        raise


