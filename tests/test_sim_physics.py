"""Simulator physics against closed forms: impact restitution and contact time, rolling at 5/7,
the bridge life cycle in the engine, neighbour lists against brute force, CG scaling."""

import dataclasses
import math

import numpy as np
import pytest

from sim.capillary import CAPILLARY_MODELS, capillary_force_scalar, rupture_distance_scalar
from sim.neighbours import _grid, max_rupture_distance, morton_rank, pair_count_reference, rebuild
from sim.params import PRESETS, SimParams, cg_scale, preset, preset_original, steps_per_contact, with_step_factor
from sim.run import Simulation
from sim.state import PARTICLE_FIELDS, SLOT_FIELDS

R = 0.75e-3
FREE = SimParams(n_particles=2, n_baffles=0, gravity=(0.0, 0.0, 0.0), drum_omega=0.0,
                 drum_radius=0.05, drum_length=0.05, viscous=False)


def closed_form(p, r):
    m_eff = p.density * 4 / 3 * math.pi * r**3 / 2
    w0 = math.sqrt(p.k_n / m_eff)
    zeta = p.c_n / (2 * math.sqrt(p.k_n * m_eff))
    return math.pi / (w0 * math.sqrt(1 - zeta**2)), math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))


def head_on(p, r, v):
    sim = Simulation.from_particles(p, [[-r - 1e-5, 0, 0.025], [r + 1e-5, 0, 0.025]], [r, r],
                                    velocity=[[v, 0, 0], [-v, 0, 0]])
    in_contact = 0
    for _ in range(5000):
        sim.advance(1)
        if np.linalg.norm(sim.state.pos[1] - sim.state.pos[0]) < 2 * r:
            in_contact += 1
        elif in_contact:
            break
    return sim, in_contact


@pytest.mark.parametrize("alpha", [1.0, 2.0])
def test_normal_impact_restitution_and_contact_time(alpha):
    p = cg_scale(dataclasses.replace(FREE, friction=0.0), alpha) if alpha > 1 else dataclasses.replace(FREE, friction=0.0)
    p = dataclasses.replace(p, drum_radius=0.05, drum_length=0.05)
    r = R * alpha
    t_c, e = closed_form(p, r)
    assert t_c / p.dt == pytest.approx(127.1, abs=0.2)  # Δt = t_c/127 at every CG level
    sim, steps = head_on(p, r, 0.05)
    vel = sim.state.vel[np.argsort(sim.state.ids)]
    assert (vel[1, 0] - vel[0, 0]) / 0.1 == pytest.approx(e, rel=3e-3)
    assert steps * p.dt == pytest.approx(t_c, rel=1.5 * p.dt / t_c)
    assert vel[:, 0].sum() == pytest.approx(0.0, abs=1e-15)  # momentum


def _restitution(p, r, v):
    sim, steps = head_on(p, r, v)
    vel = sim.state.vel[np.argsort(sim.state.ids)]
    assert vel[:, 0].sum() == pytest.approx(0.0, abs=1e-15)  # momentum
    return (vel[1, 0] - vel[0, 0]) / (2 * v), steps


@pytest.mark.parametrize("alpha", [1.0, 3.0])
def test_hertz_mindlin_impact_has_hertzs_contact_time_and_a_speed_independent_restitution(alpha):
    """The second contact law, added as one module (sim/laws/hertz_mindlin.py) and one registry
    entry: undamped (e = 1), a head-on impact rebounds elastically after Hertz's contact time
    2.9432·(15m*/(16E*√R*))^(2/5)·v^(−1/5); damped, its restitution is the same at 0.1 and
    0.4 m/s (Tsuji) and near the e it was set from; under CG nothing but the radius changes and
    t_c/Δt is the same at α = 1 and 3."""
    from sim.laws import hertz_mindlin

    original = dataclasses.replace(FREE, contact_law="hertz_mindlin", friction=0.0, restitution=1.0)
    p = cg_scale(original, alpha) if alpha > 1 else original
    assert (p.youngs_modulus, p.restitution) == (original.youngs_modulus, 1.0)
    r = R * alpha
    e, steps = _restitution(p, r, 0.05)
    assert e == pytest.approx(1.0, abs=2e-3)
    t_c = hertz_mindlin.contact_time(p, r, speed=0.1)
    assert t_c / p.dt == pytest.approx(hertz_mindlin.contact_time(original, R, speed=0.1) / original.dt, rel=1e-12)
    assert steps * p.dt == pytest.approx(t_c, rel=1.5 * p.dt / t_c)
    damped = dataclasses.replace(p, restitution=0.7)
    slow, _ = _restitution(damped, r, 0.05)
    fast, _ = _restitution(damped, r, 0.2)
    assert slow == pytest.approx(fast, rel=5e-3)
    assert 0.6 < slow < 0.8


def test_sphere_sliding_on_a_wall_ends_rolling_at_five_sevenths():
    p = dataclasses.replace(FREE, gravity=(0.0, 0.0, -9.81), n_particles=1)
    v0 = 0.05
    sim = Simulation.from_particles(p, [[0.0, 0.0, R - 2e-7]], [R], velocity=[[v0, 0, 0]])
    sim.advance(int(0.05 / p.dt))
    v = sim.state.vel[0]
    w = sim.state.omega[0]
    assert v[0] == pytest.approx(5 / 7 * v0, rel=2e-3)
    assert w[1] * R == pytest.approx(v[0], rel=2e-3)  # rolling without slip: ω_y·R = v_x


def _pull_apart(sim, v_b, max_steps):
    """Pull a bridged pair apart (fast enough to beat the bridge) until it ruptures, checking at
    every step that the bridge keeps volume ``v_b``, its gap and Willett's force at that gap;
    returns the gaps at the start of each step."""
    s = sim.state
    s.vel[:] = 0
    s.vel[np.argsort(s.ids)] = [[-0.5, 0, 0], [0.5, 0, 0]]
    model = CAPILLARY_MODELS["willett_numeric"]
    gaps = []
    for _ in range(max_steps):
        order = np.argsort(s.ids)
        gaps.append(np.linalg.norm(s.pos[order[1]] - s.pos[order[0]]) - 2 * R)
        sim.advance(1)
        live = np.flatnonzero(s.alive[2 * sim.n_walls:]) + 2 * sim.n_walls
        if not live.size:
            break
        k = live[0]
        assert s.v_b[k] == v_b
        assert s.gap[k] == pytest.approx(gaps[-1], rel=1e-9, abs=1e-18)
        expected = capillary_force_scalar(model, max(gaps[-1], 0.0), v_b, R, sim.params.surface_tension, 0.0)
        assert s.f_cap[k] == pytest.approx(expected, rel=1e-12)
    return gaps


def test_bridge_forms_at_touch_pulls_while_stretched_and_ruptures_at_s_crit():
    film = 2e-12
    p = dataclasses.replace(FREE, friction=0.0)
    sim = Simulation.from_particles(p, [[-R, 0, 0.025], [R + 1e-7, 0, 0.025]], [R, R],
                                    velocity=[[1e-3, 0, 0], [-1e-3, 0, 0]], film=[film, film])
    sim.advance(200)  # touch: the bridge takes both films, capped at V_max = 0.03 R³
    s = sim.state
    live = np.flatnonzero(s.alive[2 * sim.n_walls:]) + 2 * sim.n_walls
    assert live.size == 1
    v_max = 0.03 * R**3
    assert s.v_b[live[0]] == pytest.approx(min(2 * film, v_max), rel=1e-12)
    assert s.film[:2].sum() + s.v_b[live[0]] == pytest.approx(2 * film, rel=1e-12)
    v_b = s.v_b[live[0]]
    s_crit = rupture_distance_scalar(v_b, R, 0.0)
    gaps = _pull_apart(sim, v_b, 400)
    # it ruptured in the first step that started with s >= s_crit
    assert not s.alive[2 * sim.n_walls:].any()
    assert gaps[-2] < s_crit <= gaps[-1]
    # and gave V_b/2 back to each film
    assert s.film[:2] == pytest.approx([film - v_b / 2 + v_b / 2] * 2, rel=1e-12)


@pytest.mark.parametrize("factor", [0.5, 1.0, 1.5, 2.0, 2.5])
def test_closed_forms_hold_at_every_time_step_factor(factor):
    """--dt-factor 0.5 to 2.5 (t_c/Δt 254 to 51): restitution and contact time of a head-on impact,
    Willett's force at contact and the rupture at s_crit hold at every step the study allows."""
    p = with_step_factor(dataclasses.replace(FREE, friction=0.0), factor)
    assert p.dt == pytest.approx(FREE.dt * factor) and p.dt_factor == factor
    t_c, e = closed_form(p, R)
    assert t_c / p.dt == pytest.approx(127.1 / factor, rel=2e-3)
    assert steps_per_contact(p) == pytest.approx(t_c / p.dt, rel=1e-12)
    sim, steps = head_on(p, R, 0.05)
    vel = sim.state.vel[np.argsort(sim.state.ids)]
    assert (vel[1, 0] - vel[0, 0]) / 0.1 == pytest.approx(e, rel=3e-3)  # 0.1-0.2 % at every factor
    assert abs(steps * p.dt - t_c) <= 1.5 * p.dt
    film = 2e-12
    sim = Simulation.from_particles(p, [[-R, 0, 0.025], [R + 1e-7, 0, 0.025]], [R, R],
                                    velocity=[[1e-3, 0, 0], [-1e-3, 0, 0]], film=[film, film])
    sim.advance(round(200 / factor))
    s = sim.state
    k = np.flatnonzero(s.alive[2 * sim.n_walls:])[0] + 2 * sim.n_walls
    model = CAPILLARY_MODELS["willett_numeric"]
    assert s.f_cap[k] == pytest.approx(capillary_force_scalar(model, 0.0, s.v_b[k], R, p.surface_tension, 0.0),
                                       rel=1e-12)  # touching: Willett's force at contact
    v_b = s.v_b[k]
    gaps = _pull_apart(sim, v_b, 400)
    assert gaps[-2] < rupture_distance_scalar(v_b, R, 0.0) <= gaps[-1]


def test_the_step_factor_is_refused_beyond_the_stability_limit_and_when_not_a_positive_number():
    """The limit is 20 steps per tangential oscillation of the smallest particles (R = 0.8 R_mean;
    k_t = 0.8 k_n): a factor of 2.7 holds, 2.8 is refused."""
    for name in ("lab-cg3", "paper-cg3", "paper-cg1"):
        assert with_step_factor(preset(name), 2.7).dt == pytest.approx(2.7 * preset(name).dt)
    with pytest.raises(ValueError, match="k_t .* fewer than 20"):
        with_step_factor(FREE, 2.8)
    for bad in (0, -1.0, math.nan, math.inf, True, "2"):
        with pytest.raises(ValueError, match="time-step factor"):
            with_step_factor(FREE, bad)


def test_fixed_bridge_volume_forms_at_touch_with_v_b_and_ruptures_at_its_s_crit_without_films():
    """The fixed-bridge-volume model (YADE's ViscElCapMat without LiqControl): the bridge has V_b
    from the touch on, whatever the films; the force is Willett's at V_b; it ruptures at
    s_crit(V_b) = (1 + θ/2)(V_b^⅓ + 0.1 V_b^⅔/R*); no liquid moves to or from the films."""
    v_fixed = 0.05 * R**3  # above the film model's cap V_max = 0.03 R³: the fixed volume is not capped
    p = dataclasses.replace(FREE, friction=0.0, bridge_volume=v_fixed)
    sim = Simulation.from_particles(p, [[-R, 0, 0.025], [R + 1e-7, 0, 0.025]], [R, R],
                                    velocity=[[1e-3, 0, 0], [-1e-3, 0, 0]])
    s = sim.state
    sim.advance(200)
    live = np.flatnonzero(s.alive[2 * sim.n_walls:]) + 2 * sim.n_walls
    assert live.size == 1 and s.v_b[live[0]] == v_fixed and not s.film.any()
    s_crit = rupture_distance_scalar(v_fixed, R, 0.0)
    assert s_crit == pytest.approx(v_fixed ** (1 / 3) + 0.1 * v_fixed ** (2 / 3) / R, rel=1e-12)
    gaps = _pull_apart(sim, v_fixed, 600)
    assert not s.alive[2 * sim.n_walls:].any()
    assert gaps[-2] < s_crit <= gaps[-1]  # the Verlet reach covers the larger fixed-volume bridge
    assert max_rupture_distance(p) >= s_crit
    assert not s.film.any()  # nothing returned to the films


def test_fixed_bridge_volume_is_scaled_by_alpha_cubed_and_recorded_in_the_metadata():
    original = dataclasses.replace(preset("lab-cg1"), bridge_volume=2e-12)
    assert cg_scale(original, 2.0).bridge_volume == pytest.approx(16e-12, rel=1e-15)
    sim = Simulation.from_particles(dataclasses.replace(FREE, bridge_volume=1e-12), [[0, 0, 0.02], [0.01, 0, 0.02]],
                                    [R, R])
    config = sim.run_meta().sim_config
    assert config["liquid_model"] == "fixed_bridge_volume" and config["params"]["bridge_volume"] == 1e-12
    assert Simulation.from_particles(FREE, [[0, 0, 0.02], [0.01, 0, 0.02]], [R, R]).run_meta().sim_config[
        "liquid_model"] == "films_spray_migration"
    with pytest.raises(ValueError, match="bridge_volume"):
        dataclasses.replace(FREE, bridge_volume=-1.0)


def test_verlet_list_equals_brute_force_and_covers_bridge_range():
    rng = np.random.default_rng(3)
    n = 400
    p = dataclasses.replace(FREE, n_particles=n)
    pos = rng.uniform([-0.01, -0.01, 0.01], [0.01, 0.01, 0.02], (n, 3))
    radius = rng.uniform(0.8, 1.2, n) * R
    sim = Simulation.from_particles(p, pos, radius)
    s = sim.state
    nw = n * sim.n_walls
    reach = max_rupture_distance(p) + p.skin
    listed = {(int(min(i, j)), int(max(i, j))) for i, j in zip(s.ids[s.pair_i[nw:]], s.ids[s.pair_j[nw:]])}
    expected = pair_count_reference(pos, radius, reach)
    assert listed == expected and len(expected) > 100
    assert (s.pair_i[nw:] < s.pair_j[nw:]).all()
    key = s.pair_i[nw:] * n + s.pair_j[nw:]
    assert (np.diff(key) > 0).all()
    # the reach covers the largest rupture distance of any bridge
    r_max = p.r_max
    assert max_rupture_distance(p) >= rupture_distance_scalar(0.03 * r_max**3, r_max, 0.0)


def test_morton_rank_interleaves_the_cell_coordinates_bits():
    # a 4 x 4 x 4 grid: the rank is the key itself, x's bit before y's before z's at each level
    rank = morton_rank((4, 4, 4))
    for cx, cy, cz in [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 0, 2), (3, 2, 1), (3, 3, 3)]:
        key = sum(((c >> b) & 1) << (3 * b + 2 - axis) for b in range(2) for axis, c in enumerate((cx, cy, cz)))
        assert rank[(cx * 4 + cy) * 4 + cz] == key
    # any grid: a permutation of its cells that keeps the order of the keys, with empty keys skipped
    rank = morton_rank((5, 3, 2))
    assert sorted(rank.tolist()) == list(range(30))
    assert rank[0] == 0 and rank[(4 * 3 + 2) * 2 + 1] == 29
    assert not rank.flags.writeable


def test_rebuild_sorts_particles_by_the_morton_rank_of_their_cell_keeping_their_order_within_a_cell():
    rng = np.random.default_rng(5)
    n = 600
    p = dataclasses.replace(FREE, n_particles=n)
    sim = Simulation.from_particles(p, rng.uniform([-0.015, -0.015, 0.005], [0.015, 0.015, 0.025], (n, 3)),
                                    rng.uniform(0.8, 1.2, n) * R)
    s = sim.state
    before = s.ids.copy()
    s = rebuild(s, p, sim.n_walls)
    _, cell, lo, n_cells = _grid(p)
    coords = np.clip(np.floor((s.pos - lo) / cell).astype(np.int64), 0, n_cells - 1)
    linear = (coords[:, 0] * n_cells[1] + coords[:, 1]) * n_cells[2] + coords[:, 2]
    key = morton_rank(tuple(int(c) for c in n_cells))[linear]
    assert (np.diff(key) >= 0).all() and len(np.unique(key)) > 50
    previous_row = np.argsort(before)[s.ids]  # each particle's row before the rebuild
    same_cell = np.diff(key) == 0
    assert same_cell.any() and (np.diff(previous_row)[same_cell] > 0).all()


def test_the_particle_order_changes_no_physics():
    """The same particles given in two orders: the rebuilds order them differently within their
    cells (and orient pairs differently), so the sums run in other orders; the motion agrees to
    round-off."""
    p = dataclasses.replace(preset("lab-cg3"), settle_time=0.01, spray_interval=0.005)
    sim = Simulation(p, preset_original("lab-cg3")[0])
    sim.advance(3000)  # wet and turning: contacts, bridges and wall contacts
    s = sim.state
    n = s.n_particles
    by_id = np.argsort(s.ids)
    perm = np.random.default_rng(1).permutation(n)
    # a skin of two radii: cells of ~3 diameters, so that cells hold several particles (the
    # preset's cells hold about one, and its order would follow from the cells alone)
    wide = dataclasses.replace(p, skin=2 * p.r_mean)
    runs = []
    for order in (by_id, by_id[perm]):
        other = Simulation.from_particles(wide, s.pos[order], s.radius[order], s.vel[order], s.omega[order],
                                          s.film[:n][order])
        other.state.step = s.step
        other.advance(400)
        runs.append(other.state)
    a, b = runs
    # particle k of the second run is particle perm[k] of the first
    ia, ib = np.argsort(a.ids), np.argsort(b.ids)
    assert np.allclose(a.pos[ia][perm], b.pos[ib], rtol=0, atol=1e-12)
    assert np.allclose(a.vel[ia][perm], b.vel[ib], rtol=0, atol=1e-9)
    assert np.allclose(a.film[:n][ia][perm], b.film[:n][ib], rtol=1e-9, atol=1e-24)
    assert not np.array_equal(a.vel[ia][perm], b.vel[ib])  # the sums did run in other orders


def _interactions_by_id(s):
    """Every live slot's state keyed by its bodies' ids (a wall by −1 − wall index), a pair's
    vectors (spring = tangential force on the first body, previous normal from first to second)
    oriented from the smaller id to the larger."""
    n = s.n_particles
    out = {}
    for k in np.flatnonzero(s.alive):
        i, j = s.pair_i[k], s.pair_j[k]
        if j >= n:
            key, sign = (int(s.ids[i]), -1 - int(j - n)), 1.0
        else:
            key, sign = tuple(sorted((int(s.ids[i]), int(s.ids[j])))), (1.0 if s.ids[i] < s.ids[j] else -1.0)
        out[key] = (s.v_b[k], *(sign * s.fs[k]), *(sign * s.nprev[k]), s.v_max[k])
    return out


def test_rebuild_carries_every_interaction_state_to_its_pair_in_any_particle_order():
    p = dataclasses.replace(preset("lab-cg3"), settle_time=0.01, spray_interval=0.005)
    sim = Simulation(p, preset_original("lab-cg3")[0])
    sim.advance(12000)  # wet, sprayed, turning: live contacts and bridges, with walls
    s, nw = sim.state, sim.n_walls
    n = s.n_particles
    # scramble the particle rows (consistently), so that the rebuild has to move every row
    perm = np.random.default_rng(0).permutation(n)
    inverse = np.empty(n, dtype=np.int64)
    inverse[perm] = np.arange(n)
    for name in PARTICLE_FIELDS:
        setattr(s, name, getattr(s, name)[perm])
    s.film[:n] = s.film[:n][perm]
    rows = (perm[:, None] * nw + np.arange(nw)).ravel()
    for name in SLOT_FIELDS:
        arr = getattr(s, name)
        setattr(s, name, np.concatenate([arr[:n * nw][rows], arr[n * nw:]]))
    s.pair_i = inverse[s.pair_i]
    s.pair_j = np.where(s.pair_j < n, inverse[np.minimum(s.pair_j, n - 1)], s.pair_j)
    before = _interactions_by_id(s)
    flipped = (s.pair_j[n * nw:] < s.pair_i[n * nw:]) & s.alive[n * nw:] & (np.abs(s.fs[n * nw:]).sum(axis=1) > 0)
    assert sum(k[1] < 0 for k in before) > 10 and sum(k[1] >= 0 for k in before) > 10 and flipped.sum() > 5
    after_state = rebuild(s, p, nw)
    assert _interactions_by_id(after_state) == before
    assert (after_state.pair_i[n * nw:] < after_state.pair_j[n * nw:]).all()
    assert not (after_state.force.any() or after_state.f_cap.any() or after_state.created.any())
    r = after_state.radius
    r_min = np.minimum(r[after_state.pair_i], np.where(after_state.pair_j < n, r[np.minimum(after_state.pair_j, n - 1)], np.inf))
    assert np.array_equal(after_state.v_max, p.v_max_coef * r_min**3)
    # the slot lists: per body (particles, then walls) every slot, per particle its pair slots
    pi, pj = after_state.pair_i, after_state.pair_j
    for b in range(n + nw):
        mine = np.flatnonzero((pi == b) | (pj == b))
        assert np.array_equal(after_state.body_slots[after_state.body_start[b]:after_state.body_start[b + 1]], mine)
        if b < n:
            assert np.array_equal(after_state.part_slots[after_state.part_start[b]:after_state.part_start[b + 1]],
                                  mine[mine >= n * nw])


def test_cg_scaling_follows_table_2():
    o = SimParams()
    for alpha in (2.0, 3.0):
        c = cg_scale(o, alpha)
        assert c.d_mean == pytest.approx(o.d_mean * alpha)
        assert c.n_particles == round(o.n_particles / alpha**3)
        assert c.surface_tension == pytest.approx(o.surface_tension * alpha)
        assert c.viscosity == pytest.approx(o.viscosity * alpha)
        assert (c.k_n, c.k_t) == pytest.approx((o.k_n * alpha, o.k_t * alpha))
        assert (c.c_n, c.c_t) == pytest.approx((o.c_n * alpha**2, o.c_t * alpha**2))
        assert c.dt == pytest.approx(o.dt * alpha)
        assert cg_scale(o, alpha, scale_dt=False).dt == o.dt
        assert (c.spray_radius, c.drum_radius, c.drum_omega, c.friction) == (o.spray_radius, o.drum_radius, o.drum_omega, o.friction)
        assert (c.v_max_coef, c.spray_dose) == (o.v_max_coef, o.spray_dose)
        # forces scale as α²: capillary force at contact (γ·R) and the weight of a particle
        f_o = capillary_force_scalar(0, 1e-6, 1e-12, o.r_mean, o.surface_tension, 0.0)
        f_c = capillary_force_scalar(0, 1e-6 * alpha, 1e-12 * alpha**3, c.r_mean, c.surface_tension, 0.0)
        assert f_c == pytest.approx(alpha**2 * f_o, rel=1e-12)
        assert closed_form(c, c.r_mean)[1] == pytest.approx(closed_form(o, o.r_mean)[1])  # same restitution
    with pytest.raises(ValueError):
        cg_scale(cg_scale(o, 2.0), 2.0)
    assert preset("paper-cg3").n_particles == 4444 and preset("paper-cg1").n_particles == 120_000
    assert len(PRESETS) == 6
    with pytest.raises(ValueError, match="unknown preset"):
        preset("paper-cg4")


def test_bad_parameters_name_the_parameter():
    with pytest.raises(ValueError, match="k_n"):
        SimParams(k_n=-1.0)
    with pytest.raises(ValueError, match="capillary_model"):
        SimParams(capillary_model="magic")
    with pytest.raises(ValueError, match="unknown parameters"):
        SimParams.from_dict({"k_nn": 1})


def test_public_capillary_force_is_the_engine_law_for_a_tiny_bridge():
    """A touching CG3 pair picks up a tiny bridge (V_b = 1.7e-17 m³, a migration leftover, where
    willett_numeric is capped at 2πRγ), is pulled apart through the capped range and ruptures.
    At every step the engine's f_cap must equal sim.capillary_force of the same inputs: the
    force pass against the volume it saw, every frame against the frame's gap and volume."""
    import sim as sim_pkg

    p = dataclasses.replace(cg_scale(FREE, 3.0), drum_radius=0.05, drum_length=0.05)
    r_a, r_b = 2.2e-3, 2.5e-3
    sim = Simulation.from_particles(p, [[-r_a, 0, 0.025], [r_b + 1e-7, 0, 0.025]], [r_a, r_b],
                                    velocity=[[1e-3, 0, 0], [-1e-3, 0, 0]], film=[0.85e-17, 0.85e-17])
    s = sim.state
    k = 2 * sim.n_walls  # the only pair slot
    r_eff = 2 * r_a * r_b / (r_a + r_b)
    cap = 2 * math.pi * r_eff * p.surface_tension
    seen = set()
    for step in range(400):
        if step == 60:  # pull the pair apart, fast enough to break the bridge
            s.vel[:] = 0
            s.vel[np.argsort(s.ids)] = [[-0.02, 0, 0], [0.02, 0, 0]]
        v_before = s.v_b[k]
        sim.advance(1)
        assert s.pair_i[k] < s.pair_j[k] < 2
        if not s.alive[k]:
            if "bridge" in seen:
                seen.add("ruptured")
                break
            continue
        r1, r2 = s.radius[s.pair_i[k]], s.radius[s.pair_j[k]]
        # the force pass: what the engine applied (capillary_in_contact) or would apply when separated
        law = sim_pkg.capillary_force(s.gap[k], r1, r2, v_before, p.surface_tension, p.contact_angle)
        assert s.f_cap[k] == law, (step, s.gap[k], v_before)
        # the frame: its f_cap against its own gap, radii and bridge volume, bit for bit
        snap = sim.snapshot()
        r = snap.radius
        frame_law = sim_pkg.capillary_force(snap.gap, r[snap.contact_i], r[snap.contact_j], snap.bridge_volume,
                                            snap.meta.surface_tension, snap.meta.contact_angle)
        assert snap.n_contacts == 1 and np.array_equal(snap.f_cap, frame_law), (step, snap.gap, snap.bridge_volume, snap.f_cap)
        if s.v_b[k] > 0:
            seen.add("bridge")
            assert s.v_b[k] == pytest.approx(1.7e-17, rel=1e-12)
            if v_before == 0:
                seen.add("created")
                assert snap.f_cap[0] == pytest.approx(cap, rel=1e-12)  # touching: the capped value at contact
            elif s.gap[k] <= 0:
                seen.add("contact")
            elif s.f_cap[k] == cap:
                seen.add("separated, capped")
            else:
                seen.add("separated")
    assert seen == {"bridge", "created", "contact", "separated, capped", "separated", "ruptured"}, seen


def test_contact_law_dispatcher_and_registry():
    """The kernels call the contact law through sim.contact.contact_force with the law's packed
    constants: the linear law's f_n = k_n·u + c_n·v_n and sticking spring; an unregistered law is
    refused."""
    import dataclasses

    from sim.contact import LAW_CONSTANTS, contact_force, law_constants
    from sim.laws import CONTACT_LAWS, kernel_id
    from sim.params import SimParams

    params = SimParams()
    law, constants = law_constants(params)
    assert law == kernel_id("linear_coulomb") == 0 and len(constants) == LAW_CONSTANTS
    assert constants[:5] == (params.k_n, params.k_t, params.c_n, params.c_t, params.friction)
    u, n, v, spring, dt = 2e-6, (0.6, 0.8, 0.0), (0.01, -0.02, 0.005), (4e-5, -3e-5, 0.0), 1e-6  # sticking
    args = (u, *n, *v, *spring, 7e-4, 8e-4, dt)
    out = contact_force(law, constants, *args)
    assert out == CONTACT_LAWS["linear_coulomb"].force(constants, *args)
    v_n = float(np.dot(v, n))
    assert out[0] == pytest.approx(params.k_n * u + params.c_n * v_n, rel=1e-14)
    v_t = np.asarray(v) - v_n * np.asarray(n)
    assert np.allclose(out[1:4], np.asarray(spring) - params.k_t * dt * v_t, rtol=1e-14, atol=0)
    with pytest.raises(ValueError, match="contact_law must be one of"):
        dataclasses.replace(SimParams(), contact_law="hertz")


def test_a_contact_law_object_carries_its_parameters_contact_time_and_cg_rule(monkeypatch):
    """SimParams' fields, checks, contact time and cg_scale come from the registered laws: every
    law parameter is a field with its law's default and bound, and a scratch law (the linear
    force, with its own contact time and CG rule) is followed without an edit elsewhere."""
    import dataclasses

    from sim.laws import CONTACT_LAWS, ContactLaw, law_parameters
    from sim.params import SimParams, cg_scale

    fields = {f.name: f.default for f in dataclasses.fields(SimParams)}
    for parameter in law_parameters():
        assert fields[parameter.name] == parameter.default
        bad = {"positive": 0.0, "nonnegative": -1.0, "restitution": 1.5, "poisson_ratio": 0.5}[parameter.bound]
        with pytest.raises(ValueError, match=f"parameter {parameter.name} must be a finite number"):
            SimParams(**{parameter.name: bad})
    linear = CONTACT_LAWS["linear_coulomb"]
    scratch = ContactLaw("scratch", linear.parameters, linear.constants, linear.pack, linear.force,
                         contact_time=lambda params, radius: 0.5 * radius,
                         cg_scaled=lambda params, alpha, rule: {"k_n": params.k_n * alpha**2})
    monkeypatch.setitem(CONTACT_LAWS, "scratch", scratch)
    params = dataclasses.replace(SimParams(), contact_law="scratch")
    assert params.contact_time(1e-3) == 5e-4
    scaled = cg_scale(params, 2.0)
    assert scaled.k_n == params.k_n * 4 and scaled.k_t == params.k_t and scaled.c_n == params.c_n
    linear_cg = cg_scale(SimParams(), 2.0)
    assert (linear_cg.k_n, linear_cg.k_t, linear_cg.c_n, linear_cg.c_t) == (300.0, 240.0, 0.0011 * 4, 0.0011 * 4)


@pytest.mark.slow
def test_every_parallel_loop_of_the_step_is_compiled_parallel(tmp_path):
    """A prange loop that numba cannot parallelise (a second exit, e.g. a ``raise`` in an inlined
    function) runs on one thread with only a NumbaPerformanceWarning at compile time; the trajectory
    stays the same, so nothing else notices. Compile every kernel afresh (an empty cache) in a child
    process, run a small wet drum, and require that numba warned about no loop."""
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent("""
        import warnings
        from numba.core.errors import NumbaPerformanceWarning
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            from sim.params import SimParams
            from sim.run import Simulation
            p = SimParams(n_particles=2, n_baffles=4, drum_radius=0.02, drum_length=0.01, initial_film=0.01)
            s = Simulation.from_particles(p, [[0, -0.015, 0.005], [0.0016, -0.015, 0.005]], [7.5e-4, 7.5e-4])
            s.advance(20)
        for w in caught:
            if issubclass(w.category, NumbaPerformanceWarning):
                print("NOT PARALLEL:", str(w.message).splitlines()[0], w.filename, w.lineno)
        print("checked")
    """)
    env = {**__import__("os").environ, "NUMBA_CACHE_DIR": str(tmp_path), "NUMBA_NUM_THREADS": "2"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600,
                         cwd=__import__("os").path.dirname(__import__("os").path.dirname(__file__)))
    assert out.returncode == 0, out.stderr[-2000:]
    assert "checked" in out.stdout
    assert "NOT PARALLEL" not in out.stdout, out.stdout
