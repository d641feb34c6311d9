"""Every file a result is written to: the checks made before the work (:func:`check_outputs`,
:func:`new_output_paths`), the writers of one table, figure or JSON file (:func:`write_table`,
:func:`save_figure`, :func:`write_json`, :func:`stream_table` for a table written piece by piece),
and the outputs that are more than one file: an output folder made for the work and removed again
when it fails (:func:`output_folder`), several files that change together or not at all
(:func:`staged_outputs`), a finished folder put in the place of an earlier one
(:func:`swap_folder`). One file alone is written with
:func:`granalytics.base.files.write_atomically`."""

from __future__ import annotations

import contextlib
import json
import math
import os

from granalytics.base.errors import GranalyticsError, ParameterError
from granalytics.base.files import check_output_folder, check_replaceable, write_atomically
from granalytics.base.interrupts import interrupts_held, raise_dropped_interrupt

__all__ = ["staged_outputs", "swap_folder", "output_folder", "new_output_paths", "check_outputs", "check_new_file",
           "check_plot_path", "check_table_paths", "table_format", "write_table", "stream_table", "save_figure",
           "write_json", "json_safe"]


def new_output_paths(folder, names, *, overwrite=False) -> list:
    """The paths of the files ``names`` in ``folder``; refuses (``ParameterError``) a ``folder``
    that is a file, and files that exist unless ``overwrite`` (before the work that writes them)."""
    folder = os.fspath(folder)
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise ParameterError(f"{folder}: exists and is not a folder")
    paths = [os.path.join(folder, name) for name in names]
    existing = [p for p in paths if os.path.exists(p)]
    if existing and not overwrite:
        raise ParameterError(f"{existing[0]}: exists (overwrite=True, or --overwrite on the command line, replaces "
                             f"the {len(existing)} existing output file(s))")
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
    """Rename each staged file over its target as one change: an existing target is first kept
    beside its staged file (``….old``, a hard link where the file system has them, so that a
    process killed meanwhile leaves every target in place, old or new), and if any rename fails
    (or Ctrl-C arrives during the swap) every target done so far is put back as it was and the
    error (the interrupt) raised."""
    done = []  # (target, where its earlier version was set aside, or None if it had none)
    raise_dropped_interrupt()
    with interrupts_held() as held:
        try:
            for target, tmp in staging.items():
                old = None
                if os.path.lexists(target):
                    old = tmp + ".old"
                    try:
                        os.link(target, old, follow_symlinks=False)
                    except (OSError, NotImplementedError):  # no hard links here: moved aside
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


def json_safe(value):
    """``value`` with NaN and infinities as None: JSON has no such numbers (``json.dumps``
    would write the invalid tokens NaN and Infinity)."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


_TABLE_FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}


def table_format(path):
    """``"csv"`` or ``"parquet"``, by ``path``'s suffix (.csv, .parquet, .pq); ``ParameterError`` otherwise."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in _TABLE_FORMATS:
        raise ParameterError(f"{path}: unknown table format {ext!r} (use .csv or .parquet)")
    return _TABLE_FORMATS[ext]


def save_figure(fig, path, stage=None):
    """Write ``fig`` to ``path`` (its format from the extension), atomically, or into
    ``stage(path)`` when the command writes its outputs as one (:func:`staged_outputs`)."""
    ext = os.path.splitext(path)[1].lstrip(".").lower() or "png"
    try:
        if stage is not None:
            fig.savefig(stage(path), dpi=120, format=ext, bbox_inches="tight")  # notes below the axes included
        else:
            write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=120, format=ext, bbox_inches="tight"))
    except (OSError, ValueError) as exc:
        raise GranalyticsError(f"{path}: cannot write plot ({exc})") from None


def check_new_file(path, overwrite):
    """Before any work: refuse to replace an existing file unless ``overwrite`` (``--overwrite`` on
    the command line), a folder always, and a file whose folder does not exist or is not writable."""
    check_replaceable(path)  # a folder or a device (/dev/null) always, --overwrite or not
    if os.path.exists(path) and not overwrite:
        raise ParameterError(f"{path}: file exists (overwrite=True, or --overwrite on the command line, replaces it)")
    check_output_folder(path)


def check_plot_path(path):
    """Refuse a figure file whose extension matplotlib's Agg canvas cannot write."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    formats = sorted(FigureCanvasAgg.get_supported_filetypes())
    ext = os.path.splitext(path)[1].lstrip(".").lower()
    if ext not in formats:
        raise ParameterError(f"{path}: unknown figure format {ext!r} (use one of {', '.join(formats)})")


def check_table_paths(*paths):
    """Fail before any work if an output table has an unknown format."""
    for path in paths:
        if path:
            table_format(path)


def check_outputs(tables=(), others=(), plots=(), *, overwrite=False, run=None):
    """Before any work: output tables and figures have a known format, no two outputs are the
    same file, none is the input ``run``, none exists unless ``overwrite``, and each one's folder
    exists and is writable (``ParameterError`` naming the path otherwise). Paths that are None
    (an output not asked for) are left out."""
    paths = [p for p in (*tables, *others, *plots) if p]
    # real paths (links resolved): an output that is a link to the input is the input
    seen = {os.path.realpath(run): "the input run"} if run else {}
    for path in paths:
        key = os.path.realpath(path)
        if key in seen:
            raise ParameterError(f"{path}: the same file is given twice ({seen[key]} and an output)")
        seen[key] = path
    check_table_paths(*tables)
    for path in plots:
        if path:
            check_plot_path(path)
    for path in paths:
        check_new_file(path, overwrite)


def write_table(table, path, stage=None):
    """Write ``table`` to ``path`` (.csv or .parquet), atomically, or into ``stage(path)`` when the
    command writes its outputs as one (:func:`staged_outputs`)."""
    def write(tmp):
        if table_format(path) == "csv":
            table.to_csv(tmp, index=False)
        else:
            table.to_parquet(tmp, index=False)

    _write_output(path, write, stage)


def write_json(value, path, stage=None, *, indent=2):
    """Write ``value`` as JSON (NaN and infinities as null, :func:`json_safe`) to ``path``,
    atomically, or into ``stage(path)`` when the outputs are written as one (:func:`staged_outputs`)."""
    def write(tmp):
        with open(tmp, "w") as handle:
            json.dump(json_safe(value), handle, indent=indent)

    _write_output(path, write, stage)


def _write_output(path, write, stage) -> None:
    """``write(tmp)`` into ``stage(path)`` (outputs written as one) or atomically to ``path``; a
    failure is one line naming the file."""
    try:
        if stage is not None:
            write(stage(path))
        else:
            write_atomically(path, write)
    except OSError as exc:
        raise GranalyticsError(f"{path}: cannot write ({exc})") from None


def stream_table(pieces, path, stage=None) -> int:
    """Write the tables ``pieces`` (e.g. :func:`granalytics.analysis.particle_tables.particle_frames`) one
    after another into one file (.csv or .parquet), holding one piece in memory at a time,
    atomically, or into ``stage(path)`` when the outputs are written as one
    (:func:`staged_outputs`); returns the number of rows written.

    Parameters
    ----------
    pieces : iterable of DataFrame
        Tables with the same columns.
    path : path
        The table's file; its format from the extension (:func:`table_format`).
    """
    fmt = table_format(path)

    def write(tmp):
        rows = 0
        if fmt == "csv":
            for k, piece in enumerate(pieces):
                piece.to_csv(tmp, mode="w" if k == 0 else "a", header=k == 0, index=False)
                rows += len(piece)
            return rows
        import pyarrow as pa
        import pyarrow.parquet as pq

        writer = None
        try:
            for piece in pieces:
                batch = pa.Table.from_pandas(piece, preserve_index=False)
                writer = writer or pq.ParquetWriter(tmp, batch.schema)
                writer.write_table(batch)
                rows += len(piece)
        finally:
            if writer is not None:
                writer.close()
        return rows

    if stage is not None:
        return write(stage(path))
    return write_atomically(path, write)
