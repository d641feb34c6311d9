"""The ``info`` command: what a run file holds."""

from __future__ import annotations

import json
import warnings

from granalytics.report.files import json_safe
from granalytics.core import open_run
from granalytics.cli.options import warn_if_unfinished


def add_info_parser(sub):
    """Add the ``info`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("info", help="what a run file holds", description="Print what a run file holds: frames, particles, time span, metadata.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_info)
    return p


def cmd_info(args):
    from granalytics.analysis.confinement import confinement_of_run
    from granalytics.analysis.bed import bed_structure
    from granalytics.analysis.confinement import confinement_warning
    from granalytics.analysis.cg import cg_rule_of, cg_rule_warning

    with open_run(args.run) as run:
        warn_if_unfinished(run)
        info = run.info()
        meta = run.meta.to_dict()
        bed = bed_structure(run[len(run) - 1]) if len(run) else None
        drum = confinement_of_run(run.meta)
        rule = cg_rule_of(run.meta)
    if bed is not None and bed.planar and meta.get("drum_omega"):
        warnings.warn(f"{args.run}: planar drum run, its granules and statistics are those of stacked 2-D monolayers: "
                      f"{bed.describe()} (last frame)")
    if drum is not None and (warning := confinement_warning(drum.drum_ratio)):
        warnings.warn(f"{args.run}: {warning}")
    if warning := cg_rule_warning(rule, meta.get("alpha"), drum.drum_ratio if drum is not None else None):
        warnings.warn(f"{args.run}: {warning}")
    if args.json:
        print(json.dumps(json_safe({"file": info, "meta": meta, "bed_last_frame": bed.to_dict() if bed else None,
                                    "confinement": drum.to_dict() if drum else None}), indent=2, default=str))
        return 0
    width = max(len(k) for k in list(info) + list(meta))
    print("file")
    for key, value in info.items():
        print(f"  {key:<{width}}  {_shown(value)}")
    if bed is not None:
        print(f"  {'bed (last frame)':<{width}}  {bed.describe()}")
    if drum is not None:
        print(f"  {'drum':<{width}}  {drum.describe()}")
    sim_params = (meta.get("sim_config") or {}).get("params")
    if isinstance(sim_params, dict) and sim_params:  # a run of our simulator; runs before laws had names: the linear one
        law = sim_params.get("contact_law", "linear_coulomb")
        print(f"  {'contact law':<{width}}  {law} (the simulator's; its parameters in sim_config.params)")
        print(f"  {'CG rule':<{width}}  {rule} (α = {meta.get('alpha', 1):g}; {_RULE_SAYS.get(rule, '')})")
        print(f"  {'time step':<{width}}  {_time_step_line(sim_params, meta['sim_config'].get('steps_per_contact'))}")
        print(f"  {'cost':<{width}}  {_cost_line(meta.get('provenance') or {})}")
    print("run metadata (SI units; contact_angle in rad)")
    for key, value in meta.items():
        if key in ("sim_config", "provenance"):
            value = json.dumps(value) if value else "{}"
            if len(value) > 100:
                value = value[:97] + "..."
        print(f"  {key:<{width}}  {_shown(value)}")
    return 0


def _time_step_line(sim_params: dict, steps_per_contact) -> str:
    """``info``'s line on the simulator's step: Δt, the factor applied after the CG rule and t_c/Δt."""
    dt, factor = sim_params.get("dt"), sim_params.get("dt_factor", 1.0)
    if not isinstance(dt, (int, float)):
        return "not recorded"
    said = f"Δt = {dt:.4g} s, {factor:g} × the CG rule's step"
    if isinstance(steps_per_contact, (int, float)):
        said += f", t_c/Δt = {steps_per_contact:.4g} (mean pair)"
    return said


def _cost_line(provenance: dict) -> str:
    """``info``'s line on what the simulator's run cost: wall and CPU time (all sittings), threads
    and the rate, and the settling's wall and CPU time before frame 0, as its provenance records
    them."""
    wall, cpu = provenance.get("wall_time_s"), provenance.get("cpu_time_s")
    if not isinstance(wall, (int, float)):
        return "not recorded (a run that has not finished records its cost at its end)"
    said = f"wall {_duration(wall)}"
    said += f", CPU {_duration(cpu)}" if isinstance(cpu, (int, float)) else ", CPU not recorded"
    if isinstance(provenance.get("threads"), int):
        said += f", {provenance['threads']} thread(s) at the end"
    if isinstance(provenance.get("particle_steps_per_s"), (int, float)):
        said += f", {provenance['particle_steps_per_s'] / 1e6:.3g} M particle-steps/s (last sitting)"
    settle_wall, settle_cpu = provenance.get("settle_wall_time_s"), provenance.get("settle_cpu_time_s")
    if isinstance(settle_wall, (int, float)) and isinstance(settle_cpu, (int, float)):
        said += f"; the settling before it: wall {_duration(settle_wall)}, CPU {_duration(settle_cpu)}"
    return said


def _duration(seconds: float) -> str:
    """``seconds`` as hours and minutes, minutes and seconds, or seconds."""
    if seconds >= 3600:
        return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60)} min"
    if seconds >= 60:
        return f"{int(seconds // 60)} min {int(seconds % 60)} s"
    return f"{seconds:.3g} s"


#: what ``info`` says of a CG rule
_RULE_SAYS = {"weber": "forces × α²: the Weber number kept, the Bond number × 1/α",
              "bond": "forces × α³: the Bond and Froude numbers kept, the Weber number × 1/α"}


def _shown(value):
    """A value of ``info`` as text: floats to 6 significant digits (``--json`` keeps every digit)."""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, float) for v in value):
        return "[" + ", ".join(f"{v:.6g}" for v in value) + "]"
    return value
