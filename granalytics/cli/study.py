"""The parameter-study command ``study`` (steady-state table, Fig 7 fit, GP surrogate) of a sweep
folder that ``python -m sim sweep`` made."""

from __future__ import annotations

import math
import os

from granalytics.identification import DEFAULT_METHODS
from granalytics.base.errors import ParameterError
from granalytics.core.manifest import read_manifest
from granalytics.report.figures import growth_figure
from granalytics.analysis.study import fit_growth_of_table, fit_surrogate, study_table
from granalytics.cli.options import add_window_options, revolution_window, run_metas, threshold_options
from granalytics.report.files import check_outputs, save_figure, write_table
from granalytics.report.tables import format_study_table, format_surrogate_errors

def parse_predict(text, inputs=("gamma", "omega")) -> dict:
    """Parse ``"gamma=0.2,omega=3"`` into ``{"gamma": 0.2, "omega": 3.0}``.

    Only the names in ``inputs`` are accepted, each exactly once, every value a finite number
    (read with ``float``; nothing is evaluated). Raises :class:`ParameterError` otherwise.
    """
    values = {}
    for item in (x.strip() for x in str(text).split(",")):
        if not item:
            continue
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep:
            raise ParameterError(f"--predict: expected NAME=VALUE pairs separated by commas, got {item!r}")
        if key not in inputs:
            raise ParameterError(f"--predict: unknown input {key!r}; the inputs are {', '.join(inputs)}")
        if key in values:
            raise ParameterError(f"--predict: {key} is given twice")
        try:
            number = float(value.strip())
        except ValueError:
            raise ParameterError(f"--predict: {key} must be a number, got {value.strip()!r}") from None
        if not math.isfinite(number):
            raise ParameterError(f"--predict: {key} must be a finite number, got {value.strip()!r}")
        if key == "gamma" and number <= 0:
            raise ParameterError(f"--predict: gamma is a surface tension [N/m] and must be > 0, got {number:g}")
        if key == "omega" and number == 0:
            raise ParameterError("--predict: omega must be non-zero [rad/s] (a study's runs turn the drum)")
        values[key] = number
    missing = [k for k in inputs if k not in values]
    if missing:
        raise ParameterError(f"--predict: missing {', '.join(missing)} (give {', '.join(f'{k}=…' for k in inputs)})")
    return values


def add_study_parser(sub):
    """Add the ``study`` subcommand to ``subparsers`` (from ``ArgumentParser.add_subparsers``);
    its ``func`` is :func:`cmd_study`. Returns the subcommand's parser."""
    p = sub.add_parser(
        "study", help="analyse a parameter sweep: steady-state table, Fig 7 fit, GP surrogate",
        description="Steady-state yield, mean granule volume and granule number of every finished point of a "
                    "sweep folder (python -m sim sweep), the fit of <V_g>/V_p = β(γ − γ₁) against the paper's "
                    "β ≈ 70, γ₁ ≈ 0.027 N/m, and a Gaussian-process surrogate on (gamma, omega) with its "
                    "leave-one-out error. See docs/parameter_studies.md.")
    p.add_argument("sweep", help="sweep folder (manifest.csv and points/)")
    add_window_options(p)
    p.add_argument("--method", choices=DEFAULT_METHODS, default="gna",
                   help="identification method (default gna; a custom criterion needs the Python API, "
                        "study_table(..., method='custom', criterion=...))")
    p.add_argument("--c-agg", type=float, default=None,
                   help="cohesion threshold C_agg (default: the method's, 0.6; only for methods that take it)")
    p.add_argument("--a-agg-deg", type=float, default=None,
                   help="angle threshold A_agg in degrees (default: the method's, 20; only for methods that take it)")
    p.add_argument("--cohesion", choices=("acting", "bridge", "both"), default="both",
                   help="cohesion convention(s) of the table; fit and surrogate are reported for each, the plot "
                        "shows the first (default both: acting, bridge)")
    p.add_argument("--model", choices=("hinge", "linear"), default="hinge",
                   help="growth fit: hinge β·max(0, γ−γ₁) over all points (default) or a line through the points "
                        "with granules")
    p.add_argument("--replicas", metavar="COLUMN",
                   help="grid column that tells replicas apart (e.g. seed): points equal in every other parameter "
                        "are combined (mean, replica s.e. beside the block s.e.m.)")
    p.add_argument("--out", help="study table to write (.csv or .parquet)")
    p.add_argument("--plot", help="Fig 7 figure to write (.png, .pdf, .svg)")
    p.add_argument("--predict", action="append", metavar="gamma=G,omega=W",
                   help="surrogate prediction at this point (repeatable)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_study)
    return p


def cmd_study(args) -> int:
    """Run the ``study`` subcommand; bad input raises :class:`ParameterError` (one line, exit 2)."""
    inputs = ["gamma", "omega"]
    predictions = [parse_predict(text, inputs) for text in (args.predict or [])]
    if not os.path.isdir(args.sweep):
        raise ParameterError(f"{args.sweep}: not a folder")
    sweep = os.path.realpath(args.sweep)  # links resolved: an output linked into the sweep would overwrite it
    for path in (args.out, args.plot):
        if path and os.path.commonpath([sweep, os.path.realpath(path)]) == sweep:
            raise ParameterError(f"{path}: inside the sweep folder {args.sweep} (its manifest and points are the input)")
    check_outputs(tables=(args.out,), plots=(args.plot,), overwrite=args.overwrite)
    conventions = ["acting", "bridge"] if args.cohesion == "both" else [args.cohesion]
    params = threshold_options(args, args.method)
    manifest = read_manifest(args.sweep)
    done = manifest[manifest["status"] == "done"]
    args.window = revolution_window(args, run_metas(os.path.join(args.sweep, f) for f in done["file"]), done["point"])
    table = study_table(args.sweep, window=args.window, method=args.method, cohesion=conventions,
                        replicas=args.replicas, progress=not args.quiet, **params)
    shown_params = ", ".join(f"{k}={v:g}" for k, v in params.items())
    print(f"study of {args.sweep}: {int((manifest['status'] == 'done').sum())} finished points of {len(manifest)} in the manifest; "
          f"window [{args.window[0]:g}, {args.window[1]:g}] rev, {args.method} ({shown_params})")
    left = manifest[manifest["status"] != "done"]
    for row in left.itertuples():
        error = getattr(row, "error", "")
        error = error if isinstance(error, str) else ""  # an empty cell reads as NaN
        print(f"  left out: {row.point} ({row.status}{': ' + error if error else ''})")
    print(format_study_table(table, replicas=bool(args.replicas)))
    if args.out:
        write_table(table, args.out)
        print(f"wrote the study table ({len(table)} rows) to {args.out}")
    fits, surrogates = {}, {}
    for conv in ([None] if table["cohesion"].isna().all() else conventions):
        label = f"cohesion={conv}" if conv else "all rows"
        try:
            fits[conv] = fit_growth_of_table(table, conv, model=args.model)
            print(f"growth fit ({label}): {fits[conv].summary()}")
        except ParameterError as exc:
            print(f"growth fit ({label}): not possible: {exc}")
        try:
            surrogates[conv] = fit_surrogate(table, inputs, cohesion=conv)
            loo = surrogates[conv].loo
            print(f"surrogate ({label}; GP on {', '.join(inputs)}), leave-one-out error:")
            print(format_surrogate_errors(loo))
        except ParameterError as exc:
            print(f"surrogate ({label}): not possible: {exc}")
    if predictions:
        if not surrogates:
            raise ParameterError("--predict: no surrogate could be fitted (see above)")
        for conv, model in surrogates.items():
            for point in predictions:
                row = model.predict(point).iloc[0]
                where = ", ".join(f"{k}={point[k]:g}" for k in inputs)
                values = ", ".join(f"{name} = {row[name]:.4g} ± {row[name + '_std']:.2g} (GP std)"
                                   for name in model.outputs)
                print(f"prediction at {where}{f' (cohesion={conv})' if conv else ''}: {values}")
    if args.plot:
        import matplotlib.pyplot as plt

        conv = conventions[0] if not table["cohesion"].isna().all() else None
        fig = growth_figure(table, fits.get(conv), cohesion=conv if conv else "n/a")
        save_figure(fig, args.plot)
        print(f"wrote plot to {args.plot}")
        plt.close(fig)
    return 0

