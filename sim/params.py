"""Simulation parameters: Table 1 defaults, drum presets, and the CG scaling of Table 2.

Units are SI throughout (contact angle in radians). ``SimParams`` is a frozen dataclass: derive
variants with :func:`dataclasses.replace`, and coarse-grain with :func:`cg_scale`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .capillary import CAPILLARY_MODELS
from .cg_rules import CG_RULES, DEFAULT_CG_RULE, cg_rule
from .laws import CONTACT_LAWS, law_parameters

__all__ = ["SimParams", "cg_scale", "PRESETS", "preset", "preset_original", "PHYSICS_VERSION", "MIN_PARTICLES",
           "check_cg_particle_count", "frame_interval_steps", "similar_system", "sized_drum", "DrumRule",
           "FILL_FRACTION", "FILL_PACKING"]

#: The simulator's physics version, raised by every change that alters trajectories on purpose
#: (recorded in checkpoints, in the runs' provenance and in sweep manifests; a run is never
#: resumed across versions; docs/simulator.md, "Physics versions"). 1: up to 2026-11-30; 2: a
#: pair's friction spring and previous normal re-oriented when a rebuild swaps the pair's particles;
#: 3 (2026-12-02): a 3-D initial packing (jittered bcc lattice, sim.packing) instead of a simple
#: cubic lattice that kept every run a stack of planar monolayers, and the settled-bed check; 4: the
#: particles re-sorted by the Morton rank of their cell at each rebuild (the forces are summed in
#: another order: trajectories differ in their last bits, then chaotically; statistics unchanged).
PHYSICS_VERSION = 4

CAPILLARY_MODEL_NAMES = tuple(CAPILLARY_MODELS)
#: Δt must resolve the contact of the smallest particles with at least this many steps
MIN_STEPS_PER_CONTACT = 20

#: the most flat facets of a polygonal cylinder (YADE's facetCylinder uses tens; each is a wall)
MAX_CYLINDER_FACETS = 10_000


def _with_law_parameters(cls):
    """Give ``cls`` every registered contact law's parameters (:func:`sim.laws.law_parameters`)
    as float fields with the law's defaults, placed after ``d_spread`` (so the field order, and
    with it every run's recorded ``sim_config``, is that of the laws' declarations)."""
    annotations = {}
    for name, kind in cls.__dict__.get("__annotations__", {}).items():
        annotations[name] = kind
        if name == "d_spread":
            for parameter in law_parameters():
                annotations[parameter.name] = "float"
                setattr(cls, parameter.name, parameter.default)
    cls.__annotations__ = annotations
    return cls


@dataclass(frozen=True)
@_with_law_parameters
class SimParams:
    """Everything that defines a run. Defaults are Table 1 of the paper (α = 1).

    Material and contact (pair values)
        density [kg/m³], d_mean [m] (diameters uniform in [1 − d_spread, 1 + d_spread]·d_mean),
        contact_law (a name of ``sim.laws.CONTACT_LAWS``, default the linear viscoelastic law with
        Coulomb friction), and every registered law's parameters, each a field with its law's
        default (``sim.laws.law_parameters()``; the linear law's: k_n, k_t [N/m], c_n, c_t
        [N s/m], friction μ).
    Liquid
        surface_tension γ [N/m], viscosity η [Pa s], contact_angle θ [rad], capillary_model,
        viscous (Pitois lubrication force on/off), capillary_in_contact (YADE: False),
        v_max_coef (V_max = coef·min(R)³), v_min (minimum film [m³]),
        spray_interval [s], spray_dose (fraction of V_p per spray), spray_radius r_s [m],
        initial_film (fraction of V_p at t = 0).
        bridge_volume V_b [m³]: 0 (default) for films, spraying and migration; > 0 for the
        fixed-bridge-volume model of YADE's ``ViscElCapMat`` without ``LiqControl``: every bridge
        (particle or wall) has volume V_b from the moment it forms (pairs touching at the end of
        the dry settling included) until it ruptures; no films, no spraying, no migration.
        wall_bridges (fixed-bridge-volume model only): False makes every wall contact dry (no
        bridge with the drum, its baffles or end plates; YADE's walls of a material with
        ``Capillar=False``).
    Drum
        drum_radius R_d [m], drum_length L [m], n_baffles, baffle_height (fraction of R_d),
        cylinder_facets (0: the smooth cylinder; N >= 3: a polygon of N flat facets with its
        vertices on R_d, turning with the drum, as YADE's ``facetCylinder``),
        drum_omega Ω [rad/s] about +z, gravity [m/s²], fill_fraction (bed volume / drum volume at
        packing 0.6, used only to document presets), n_particles.
    Numerics
        dt [s] (at most t_c/20, t_c = :meth:`contact_time` of the smallest particles);
        dt_factor: the factor by which ``dt`` was multiplied after the CG rule set it
        (:func:`with_step_factor`, ``--dt-factor``; 1 for the paper's step, recorded so that a run
        says how its step was chosen); skin [m] (Verlet skin beyond the bridge range),
        settle_time [s] (static drum, dry, before t = 0), seed.
    CG
        alpha (CG factor of *these* parameters), and the original (α = 1) values are recovered
        by :func:`cg_scale` metadata; cg_rule (a name of ``sim.cg_rules.CG_RULES``, default
        ``weber``, Table 2): the rule by which these parameters were, or will be, coarse-grained
        (recorded at α = 1 too, where it changes nothing).
    """

    n_particles: int = 5000
    density: float = 2500.0
    d_mean: float = 1.5e-3
    d_spread: float = 0.2
    # (here: the contact laws' parameters, added by _with_law_parameters)
    surface_tension: float = 0.1095
    viscosity: float = 0.0015
    contact_angle: float = 0.0
    capillary_model: str = "willett_numeric"
    contact_law: str = "linear_coulomb"
    viscous: bool = True
    capillary_in_contact: bool = False
    v_max_coef: float = 0.03
    v_min: float = 0.0
    spray_interval: float = 0.2
    spray_dose: float = 0.01
    spray_radius: float = 0.063
    initial_film: float = 0.0
    bridge_volume: float = 0.0
    drum_radius: float = 0.1
    drum_length: float = 0.045
    n_baffles: int = 4
    baffle_height: float = 0.15
    cylinder_facets: int = 0
    wall_bridges: bool = True
    drum_omega: float = 2.0
    gravity: tuple = (0.0, -9.81, 0.0)
    dt: float = 3e-6
    dt_factor: float = 1.0
    skin: float = 0.3e-3
    settle_time: float = 0.3
    seed: int = 0
    alpha: float = 1.0
    cg_rule: str = DEFAULT_CG_RULE

    def __post_init__(self):
        for parameter in law_parameters():
            parameter.check(getattr(self, parameter.name))
        positive = ("density", "d_mean", "surface_tension", "dt", "dt_factor", "drum_radius",
                    "drum_length", "spray_interval", "alpha", "v_max_coef")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"parameter {name} must be a finite number > 0, got {value!r}")
        nonneg = ("viscosity", "v_min", "spray_dose", "spray_radius",
                  "initial_film", "skin", "settle_time", "baffle_height", "bridge_volume")
        for name in nonneg:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"parameter {name} must be a finite number >= 0, got {value!r}")
        if not 0 <= self.d_spread < 1:
            raise ValueError(f"parameter d_spread must be in [0, 1), got {self.d_spread!r}")
        if not 0 <= self.contact_angle < math.pi / 2:
            raise ValueError(f"parameter contact_angle must be in [0, π/2) rad, got {self.contact_angle!r}")
        if self.contact_law not in CONTACT_LAWS:
            raise ValueError(f"parameter contact_law must be one of {tuple(CONTACT_LAWS)}, got {self.contact_law!r}")
        if self.cg_rule not in CG_RULES:
            raise ValueError(f"parameter cg_rule must be one of {tuple(CG_RULES)}, got {self.cg_rule!r}")
        if self.cg_rule not in CONTACT_LAWS[self.contact_law].cg_rules:
            raise ValueError(f"the contact law {self.contact_law!r} has no CG rule {self.cg_rule!r} (it has "
                             f"{', '.join(CONTACT_LAWS[self.contact_law].cg_rules)})")
        if self.capillary_model not in CAPILLARY_MODEL_NAMES:
            raise ValueError(f"parameter capillary_model must be one of {CAPILLARY_MODEL_NAMES}, got {self.capillary_model!r}")
        if not (isinstance(self.n_particles, int) and self.n_particles > 0):
            raise ValueError(f"parameter n_particles must be a positive integer, got {self.n_particles!r}")
        if not (isinstance(self.n_baffles, int) and self.n_baffles >= 0):
            raise ValueError(f"parameter n_baffles must be a non-negative integer, got {self.n_baffles!r}")
        if not (isinstance(self.cylinder_facets, int) and (self.cylinder_facets == 0 or
                                                           3 <= self.cylinder_facets <= MAX_CYLINDER_FACETS)):
            raise ValueError(f"parameter cylinder_facets must be 0 (smooth) or an integer in [3, {MAX_CYLINDER_FACETS}], "
                             f"got {self.cylinder_facets!r}")
        if not self.wall_bridges and not self.bridge_volume > 0:
            raise ValueError("parameter wall_bridges=False needs the fixed-bridge-volume model (bridge_volume > 0)")
        if not self.baffle_height < 1:
            raise ValueError(f"parameter baffle_height must be < 1 (fraction of the drum radius), got {self.baffle_height!r}")
        if len(self.gravity) != 3:
            raise ValueError(f"parameter gravity must have 3 components, got {self.gravity!r}")
        if self.d_mean * (1 + self.d_spread) * 3 > self.drum_length:
            raise ValueError(f"drum_length {self.drum_length} m is shorter than 3 particle diameters")
        if not (isinstance(self.seed, int) and not isinstance(self.seed, bool) and self.seed >= 0):
            raise ValueError(f"parameter seed must be a non-negative integer, got {self.seed!r}")
        # time step: at least MIN_STEPS_PER_CONTACT steps per contact of the smallest particles
        r_min = self.r_mean * (1 - self.d_spread)
        t_c = self.contact_time(r_min)
        if self.dt > t_c / MIN_STEPS_PER_CONTACT:
            raise ValueError(
                f"parameter dt = {self.dt:.3g} s is above t_c/{MIN_STEPS_PER_CONTACT} = {t_c / MIN_STEPS_PER_CONTACT:.3g} s, "
                f"where t_c = {t_c:.3g} s is the contact time of the smallest particles (R = {r_min:.3g} m); "
                f"that is {t_c / self.dt:.3g} steps per contact")
        self._check_stability(r_min, t_c)

    def _check_stability(self, r_min: float, t_c: float) -> None:
        """Refuse (ValueError naming the parameter) values the explicit integration cannot resolve
        or that leave the models' range, for the lightest pair (two particles of radius r_min):
        the contact law's own limits (:attr:`sim.laws.ContactLaw.check`); a capillary force at
        contact, 2πRγ, above what the contact carries at 10 % overlap (m*(π/t_c)²·0.1R: the
        bridges would crush the particles into each other); a viscous force whose damping at the
        gap floor, 6πηR*²/(10⁻³R*), exceeds m*/Δt (explicit damping unstable); a fixed bridge
        volume above 0.1 R³ (beyond Willett's fits)."""
        m_pair = self.density * 4 / 3 * math.pi * r_min**3 / 2
        CONTACT_LAWS[self.contact_law].check(self, r_min, m_pair)
        capillary = 2 * math.pi * r_min * self.surface_tension
        carried = m_pair * (math.pi / t_c) ** 2 * 0.1 * r_min
        if capillary > carried:
            raise ValueError(f"parameter surface_tension = {self.surface_tension:.3g} N/m: the capillary force at contact of "
                             f"the smallest particles, 2πRγ = {capillary:.3g} N, exceeds what their contact carries at 10 % "
                             f"overlap ({carried:.3g} N): stiffen the contact law or lower γ")
        if self.viscous:
            r_star = r_min / 2
            damping = 6 * math.pi * self.viscosity * r_star * 1e3
            if damping * self.dt > m_pair:
                raise ValueError(f"parameter viscosity = {self.viscosity:.3g} Pa s: the viscous force's damping at the gap "
                                 f"floor ({damping:.3g} N s/m) times Δt exceeds the smallest pair's mass "
                                 f"({damping * self.dt / m_pair:.3g}×): the explicit integration would be unstable; lower "
                                 "η or Δt")
        if self.bridge_volume > 0.1 * r_min**3:
            raise ValueError(f"parameter bridge_volume = {self.bridge_volume:.3g} m³ is above 0.1 R³ = {0.1 * r_min**3:.3g} m³ "
                             f"of the smallest particles (R = {r_min:.3g} m), beyond the range of Willett's capillary "
                             "force fits (V/R³ ≤ 0.1)")

    # ---- derived quantities
    @property
    def r_mean(self) -> float:
        """Mean particle radius [m]."""
        return self.d_mean / 2

    @property
    def r_max(self) -> float:
        """Largest particle radius [m]."""
        return self.r_mean * (1 + self.d_spread)

    @property
    def revolution_period(self) -> float:
        """2π/Ω [s] (inf for a static drum)."""
        return 2 * math.pi / abs(self.drum_omega) if self.drum_omega else math.inf

    def contact_time(self, radius=None) -> float:
        """Closed-form normal contact time of two equal spheres of ``radius`` (default the mean
        radius) under the run's contact law (:attr:`sim.laws.ContactLaw.contact_time`; the
        linear law's π/(ω₀√(1−ζ²))) [s].

        Raises
        ------
        ValueError
            If the contact is overdamped (ζ ≥ 1: no rebound, no contact time).
        """
        return CONTACT_LAWS[self.contact_law].contact_time(self, self.r_mean if radius is None else radius)

    def to_dict(self) -> dict:
        """JSON-serialisable form."""
        out = dataclasses.asdict(self)
        out["gravity"] = list(self.gravity)
        return out

    @classmethod
    def from_dict(cls, data) -> "SimParams":
        """Inverse of :meth:`to_dict`; unknown keys raise ``ValueError`` naming them."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(f"unknown parameters {unknown}")
        data = dict(data)
        if "gravity" in data:
            data["gravity"] = tuple(data["gravity"])
        return cls(**data)


def cg_scale(params: SimParams, alpha: float, *, scale_dt: bool = True) -> SimParams:
    """Coarse-grain the *original* (α = 1) parameters by a factor α under their rule
    ``params.cg_rule`` (:mod:`sim.cg_rules`; docs/physics.md, "Coarse-graining rules").

    Radii ×α, particle count ×1/α³ (rounded), Verlet skin ×α, a fixed bridge volume V_b ×α³;
    γ and η × α^(f−1), Δt × α^((4−f)/2) (unless ``scale_dt=False``) and the contact law's
    parameters by its own rule (:attr:`sim.laws.ContactLaw.cg_scaled`; the linear law: k_n, k_t
    × α^(f−1), c_n, c_t × α^((f+2)/2)), where every force scales as α^f: f = 2 for ``weber``
    (Table 2 of the paper: γ, η, k ×α; c ×α²; Δt ×α), f = 3 for ``bond`` (γ, η, k ×α²; c ×α^2.5;
    Δt ×α^0.5). Volumes per particle follow the radius (same fractions of V_p, so V_max, spray
    dose and initial film coefficients are unchanged); drum, spray zone, Ω, gravity, friction,
    contact angle, density, spray interval and settling time unchanged.

    Raises
    ------
    ValueError
        If ``params`` is already coarse-grained (``alpha != 1``) or ``alpha < 1``.
    """
    if params.alpha != 1.0:
        raise ValueError(f"cg_scale expects original (alpha = 1) parameters, got alpha = {params.alpha}")
    if not (math.isfinite(alpha) and alpha >= 1):
        raise ValueError(f"CG factor alpha must be >= 1, got {alpha!r}")
    rule = cg_rule(params.cg_rule)
    liquid = rule.surface_tension(alpha)
    return dataclasses.replace(
        params,
        alpha=float(alpha),
        n_particles=max(1, int(round(params.n_particles / alpha**3))),
        d_mean=params.d_mean * alpha,
        surface_tension=params.surface_tension * liquid,
        viscosity=params.viscosity * liquid,
        **CONTACT_LAWS[params.contact_law].cg_scaled(params, alpha, rule),
        dt=params.dt * rule.time_step(alpha) if scale_dt else params.dt,
        skin=params.skin * alpha,
        bridge_volume=params.bridge_volume * alpha**3,
    )


def with_step_factor(params: SimParams, factor: float) -> SimParams:
    """``params`` with the time step Δt × ``factor`` (and ``dt_factor`` × ``factor``, the record of it).

    Applied last, after the CG rule and the twin, so that ``factor`` multiplies the step the
    rule gives: ``--dt-factor 2.5`` on CG3 is 2.5 × (3 µs × 3). The paper's step is factor 1;
    ``docs/simulator.md`` ("Time step") gives the factors measured to leave the statistics
    unchanged.

    Raises
    ------
    ValueError
        If ``factor`` is not a finite number > 0, or the step it gives exceeds t_c/20 of the
        smallest particles (or another stability limit of :class:`SimParams`).
    """
    if not (isinstance(factor, (int, float)) and not isinstance(factor, bool) and math.isfinite(factor)
            and factor > 0):
        raise ValueError(f"the time-step factor must be a finite number > 0, got {factor!r}")
    if factor == 1:
        return params
    return dataclasses.replace(params, dt=params.dt * factor, dt_factor=params.dt_factor * factor)


def steps_per_contact(params: SimParams) -> float:
    """t_c/Δt for a pair of mean particles (t_c = :meth:`SimParams.contact_time`): how finely
    the step resolves a typical contact (the paper's step: about 127 for the linear law)."""
    return params.contact_time() / params.dt


def similar_system(params: SimParams, length_factor: float) -> SimParams:
    """The dynamically similar system with every length × λ = ``length_factor`` under the same
    gravity: times × √λ (Δt, revolution period, spray interval, settling time), masses and forces
    × λ³ (the contact law's parameters as the ``bond`` rule scales them, γ × λ², η × λ^1.5),
    volumes × λ³, particle count, α, rule and dimensionless parameters unchanged.

    Every dimensionless group (Bond, Froude, Weber, capillary, restitution, t_c/Δt, D/d, fill) is
    that of ``params``, so the two runs are one run in other units: ``similar_system(cg, 1/α)``
    of a ``bond``-rule CG run (with ``alpha`` set to 1) is its α = 1 *twin*, whose statistics
    must equal the CG run's within replica errors (``benchmarks/cg_twin.py``).
    """
    lam = float(length_factor)
    if not (math.isfinite(lam) and lam > 0):
        raise ValueError(f"length_factor must be a finite number > 0, got {length_factor!r}")
    root = math.sqrt(lam)
    return dataclasses.replace(
        params,
        d_mean=params.d_mean * lam,
        **CONTACT_LAWS[params.contact_law].cg_scaled(params, lam, CG_RULES["bond"]),
        surface_tension=params.surface_tension * lam**2,
        viscosity=params.viscosity * lam**1.5,
        v_min=params.v_min * lam**3,
        spray_interval=params.spray_interval * root,
        spray_radius=params.spray_radius * lam,
        bridge_volume=params.bridge_volume * lam**3,
        drum_radius=params.drum_radius * lam,
        drum_length=params.drum_length * lam,
        drum_omega=params.drum_omega / root,
        dt=params.dt * root,
        skin=params.skin * lam,
        settle_time=params.settle_time * root,
    )


#: fewest particles a run may have after coarse-graining
MIN_PARTICLES = 2


def check_cg_particle_count(n_original: int, alpha: float, what: str | None = None) -> int:
    """The particle count round(N/α³) of the system coarse-grained from ``n_original`` particles
    (``what``: how the messages call that count, default "N original particles").

    Raises
    ------
    ValueError
        Fewer than :data:`MIN_PARTICLES` after coarse-graining (:func:`cg_scale` itself keeps at
        least one particle and would run a meaningless system).
    """
    per_particle = n_original / (alpha * alpha * alpha)  # not alpha**3: that raises for a huge alpha
    scaled = round(per_particle)
    if scaled < MIN_PARTICLES:
        raise ValueError(f"{what or f'{n_original} original particles'}: {scaled} particles after coarse-graining by "
                         f"α = {alpha:g} ({n_original}/α³ = {per_particle:.3g}, rounded); at least {MIN_PARTICLES} "
                         "are needed")
    return scaled


def frame_interval_steps(revolutions: float, frame_every_rev: float, params: SimParams,
                         names=("revolutions", "frame_every_rev")) -> int:
    """Time steps per output frame for a frame every ``frame_every_rev`` drum revolutions of
    the (possibly coarse-grained) system ``params``, after checking the run's frame plan.

    ``revolutions`` must be a whole number of frame intervals (so that the last frame is at
    the requested end) and a frame interval at least one time step; ``names`` are how the two
    quantities are called in the messages (the command line's options, a sweep spec's keys).

    Raises
    ------
    ValueError
        The run would need more than 2**62 time steps, or either check fails.
    """
    rev_name, every_name = names
    per_revolution = params.revolution_period / params.dt
    if not revolutions * per_revolution < 2.0**62:
        raise ValueError(f"{rev_name} {revolutions:g} needs {revolutions * per_revolution:.3g} time steps, more than "
                         f"can be counted (Δt = {params.dt:g} s; one revolution at Ω = {params.drum_omega:g} rad/s "
                         f"is {per_revolution:.3g} steps)")
    ratio = revolutions / frame_every_rev
    n = round(ratio)
    if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
        raise ValueError(f"{rev_name} {revolutions:g} is not a whole number of {every_name} {frame_every_rev:g} "
                         f"intervals ({ratio:.6g}); the last frame would miss the requested end")
    steps = frame_every_rev * per_revolution
    if steps < 1:
        raise ValueError(f"{every_name} {frame_every_rev:g} is shorter than one time step "
                         f"(Δt = {params.dt:g} s, {per_revolution:.6g} steps per revolution)")
    return int(round(steps))


#: the bed's packing fraction the fill rule assumes
FILL_PACKING = 0.6
#: bed volume (at FILL_PACKING) / drum volume of every preset drum
FILL_FRACTION = 0.25


@dataclass(frozen=True)
class DrumRule:
    """How a preset's drum is sized for its particles: the same fill, aspect and spray zone at
    any size (the drum's confinement, D/d, is then set by the particle count).

    Attributes
    ----------
    aspect : float
        Axial length over radius, L/R_d.
    spray_fraction : float
        Spray radius over drum radius, r_s/R_d.
    """

    aspect: float
    spray_fraction: float = 0.63

    def radius_for(self, n_particles: float, d_mean: float) -> float:
        """Drum radius R_d [m] that ``n_particles`` spheres of mean diameter ``d_mean`` [m] fill to
        :data:`FILL_FRACTION` at packing :data:`FILL_PACKING`."""
        bed_volume = n_particles * math.pi * d_mean**3 / 6 / FILL_PACKING
        return (bed_volume / (FILL_FRACTION * math.pi * self.aspect)) ** (1 / 3)

    def particles_for(self, radius: float, d_mean: float) -> float:
        """Inverse of :meth:`radius_for`: the (fractional) particle count that fills a drum of
        radius ``radius`` [m]."""
        return FILL_FRACTION * math.pi * self.aspect * radius**3 * FILL_PACKING / (math.pi * d_mean**3 / 6)

    def drum(self, original: SimParams, radius: float, n_original: int) -> SimParams:
        """``original`` in a drum of ``radius`` [m] with ``n_original`` particles (length and spray
        zone from the rule; baffles, Ω and physics unchanged)."""
        return dataclasses.replace(original, n_particles=n_original, drum_radius=radius,
                                   drum_length=self.aspect * radius, spray_radius=self.spray_fraction * radius)


#: the lab drum: the paper's fill and r_s/R_d, axial length L = 0.7 R_d (the paper's drum has
#: 0.45; longer here so that the largest CG3 particles, 5.4 mm, still span more than three
#: diameters)
_DRUM_RULES = {"lab": DrumRule(aspect=0.7), "paper": DrumRule(aspect=0.45)}


def _lab(n_particles):
    """The lab drum (:data:`_DRUM_RULES`) holding ``n_particles`` original particles of 1.5 mm."""
    rule = _DRUM_RULES["lab"]
    return rule.drum(SimParams(n_particles=n_particles), rule.radius_for(n_particles, 1.5e-3), n_particles)


#: original (α = 1) parameter sets; the CG presets derive from them with cg_scale.
_ORIGINALS = {
    "paper": SimParams(n_particles=120_000, drum_radius=0.1, drum_length=0.045, spray_radius=0.063),
    # 3 000 particles: lab-cg1 runs 3 revolutions (9.4e9 particle-steps) in under two hours on
    # one core of the 2-core dev machine (measured 1.5e6 particle-steps/s per core in the wet drum
    # with a second run on the other core), so that the whole CG1/CG2/CG3 comparison fits one
    # sitting beside the paper-drum runs; lab-cg2 = 375, lab-cg3 = 111 particles.
    "lab": _lab(3_000),
}


def sized_drum(preset_name: str, original: SimParams, alpha: float, *, drum_ratio: float | None = None,
               drum_particles: int | None = None) -> SimParams:
    """The original (α = 1) system of a preset in a drum of the preset's geometry rule
    (:class:`DrumRule`: fill, L/R_d, r_s/R_d, baffles) sized for a confinement or a particle count.

    Parameters
    ----------
    preset_name : str
        A name of :data:`PRESETS`; its base (``lab`` or ``paper``) picks the rule.
    original : SimParams
        The original parameters (other overrides already applied); its ``d_mean`` is the
        original particles' diameter.
    alpha : float
        The CG factor the run will be coarse-grained by.
    drum_ratio : float, optional
        D/d of the *simulated* system: drum diameter over the mean diameter of the (CG)
        particles, 2·R_d / (α·d_mean). The drum's radius is exactly this; the particle count
        is rounded to the nearest whole number of simulated particles.
    drum_particles : int, optional
        Particle count of the *simulated* system; the original holds round(α³·N) particles and
        the drum is sized for them.

    Returns
    -------
    SimParams
        ``original`` unchanged when neither is given.

    Raises
    ------
    ValueError
        Both given, a value out of range, or too few particles after coarse-graining.
    """
    if drum_ratio is None and drum_particles is None:
        return original
    if drum_ratio is not None and drum_particles is not None:
        raise ValueError("give the drum's size by drum_ratio (D/d) or by drum_particles, not both")
    rule = _DRUM_RULES[preset_name.rsplit("-cg", 1)[0]]
    d = original.d_mean
    if drum_ratio is not None:
        if not (isinstance(drum_ratio, (int, float)) and math.isfinite(drum_ratio) and drum_ratio >= 4):
            raise ValueError(f"drum_ratio (D/d) must be a finite number >= 4, got {drum_ratio!r}")
        radius = drum_ratio * alpha * d / 2
        n_simulated = max(1, round(rule.particles_for(radius, alpha * d)))
    else:
        if not (isinstance(drum_particles, int) and not isinstance(drum_particles, bool) and drum_particles >= MIN_PARTICLES):
            raise ValueError(f"drum_particles must be a whole number >= {MIN_PARTICLES}, got {drum_particles!r}")
        n_simulated = drum_particles
        radius = rule.radius_for(n_simulated, alpha * d)
    n_original = round(n_simulated * alpha**3)
    check_cg_particle_count(n_original, alpha, f"a drum of D/d = {2 * radius / (alpha * d):.3g}")
    return rule.drum(original, radius, n_original)


#: the presets' names: the lab and paper drums at CG levels 1, 2 and 3 (`python -m sim presets`)
PRESETS = tuple(f"{base}-cg{a}" for base in _ORIGINALS for a in (1, 2, 3))


def preset_original(name: str) -> tuple[SimParams, float]:
    """The original (α = 1) parameters and the CG factor of a named preset."""
    try:
        base, cg = name.rsplit("-cg", 1)
        original = _ORIGINALS[base]
        alpha = float(int(cg))
        if alpha not in (1.0, 2.0, 3.0):
            raise ValueError
    except (ValueError, KeyError):
        raise ValueError(f"unknown preset {name!r}; available: {', '.join(PRESETS)}") from None
    return original, alpha


def preset(name: str) -> SimParams:
    """Parameters of a named preset: ``paper-cg1|2|3`` (120 000 particles at α = 1, R_d = 0.1 m)
    or ``lab-cg1|2|3`` (3 000 particles at α = 1 in a drum scaled to the same fill)."""
    original, alpha = preset_original(name)
    return original if alpha == 1 else cg_scale(original, alpha)
