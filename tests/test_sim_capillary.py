"""Liquid-bridge forces (sim.capillary) against docs/physics.md ("Liquid bridges", "Capillary models")
and YADE 2023.02a curves."""

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numba import njit

from sim.capillary import (
    CAPILLARY_MODELS,
    bridge_constants,
    bridge_force,
    bridge_force_from_constants,
    capillary_force_scalar,
    capillary_force_curve,
    rupture_distance_scalar,
    viscous_force,
)

CSV_NAME = "yade_capillary_equal_spheres.csv"
CSV_CANDIDATES = (Path(__file__).resolve().parent / "data" / CSV_NAME,)  # inside the repository only
YADE_NAMES = {
    "Willett_numeric": "willett_numeric",
    "Willett_analytic": "willett_analytic",
    "Rabinovich": "rabinovich",
    "Lambert": "lambert",
}
GAMMA = 0.1095  # N/m
R = 0.75e-3  # m
V_B = 1e-12  # m³


@pytest.fixture(scope="module")
def yade():
    for path in CSV_CANDIDATES:
        if path.is_file():
            table = pd.read_csv(path)
            table["r_eff"] = 2 * table.r1_m * table.r2_m / (table.r1_m + table.r2_m)
            return table
    pytest.skip(f"YADE reference {CSV_NAME} not found in " + ", ".join(map(str, CSV_CANDIDATES)))


def _rel_err(got, want):
    return np.abs(np.asarray(got) / np.asarray(want) - 1.0)


# --- YADE reference curves -------------------------------------------------------------------

@pytest.mark.parametrize("yade_name", sorted(YADE_NAMES))
def test_force_matches_yade_curves(yade, yade_name):
    rows = yade[(yade.capillary_type == yade_name) & (yade.bridge_active == 1)]
    assert len(rows) > 300  # three volumes, every separation until rupture
    got = capillary_force_curve(YADE_NAMES[yade_name], rows.gap_m, rows.bridge_volume_m3,
                                rows.r_eff, rows.surface_tension_N_per_m, rows.contact_angle_rad)
    err = _rel_err(got, rows.attractive_force_N)
    worst = int(np.argmax(err))
    assert err[worst] <= 1e-6, rows.iloc[worst].to_dict() | {"ours": got[worst]}


def test_rupture_distance_matches_yade(yade):
    got = np.array([rupture_distance_scalar(v, r, t) for v, r, t in
                    zip(yade.bridge_volume_m3, yade.r_eff, yade.contact_angle_rad)])
    assert _rel_err(got, yade.yade_s_crit_m).max() <= 1e-6
    active = yade.bridge_active.to_numpy() == 1
    assert active.any() and (~active).any()
    assert np.all(yade.gap_m.to_numpy()[active] < got[active])
    assert np.all(yade.gap_m.to_numpy()[~active] >= got[~active])


def test_rupture_distance_spec_check_values():
    assert rupture_distance_scalar(1e-12, 0.75e-3, 0.0) == pytest.approx(1.013333e-4, rel=5e-7)
    r_i, r_j = 0.5e-3, 1e-3
    r_eff = 2 * r_i * r_j / (r_i + r_j)
    assert rupture_distance_scalar(1e-12, r_eff, 0.0) == pytest.approx(1.0150e-4, rel=5e-5)


def test_rupture_distance_grows_with_contact_angle():
    # (1 + θ/2) prefactor
    assert rupture_distance_scalar(V_B, R, 1.0) == pytest.approx(1.5 * rupture_distance_scalar(V_B, R, 0.0),
                                                          rel=1e-14)


# --- check values of "Capillary models" --------------------------------------------------------------------

SPEC_TABLE = {
    "willett_analytic": (5.00671e-4, 3.49822e-4, 1.45347e-4, 7.24192e-5),
    "willett_numeric": (4.63040e-4, 3.38582e-4, 1.56616e-4, 8.41947e-5),
    "rabinovich": (5.17433e-4, 3.62669e-4, 1.53924e-4, 7.55617e-5),
    "lambert": (4.98306e-4, 3.48488e-4, 1.45835e-4, 7.01667e-5),
}
SPEC_GAPS = (1e-6, 1e-5, 3e-5, 5e-5)


def test_spec_table_covers_every_model():
    assert set(SPEC_TABLE) == set(CAPILLARY_MODELS)


@pytest.mark.parametrize("model", sorted(SPEC_TABLE))
def test_spec_reference_table(model):
    got = capillary_force_curve(model, SPEC_GAPS, V_B, R, GAMMA)
    assert _rel_err(got, SPEC_TABLE[model]).max() <= 1e-5


def test_willett_analytic_spec_check_value():
    got = capillary_force_scalar(CAPILLARY_MODELS["willett_analytic"], 1.875e-6, V_B, R, GAMMA, 0.0)
    assert got == pytest.approx(4.86565e-4, rel=1e-5)


# --- limits ------------------------------------------------------------------------------------

@pytest.mark.parametrize("theta", [0.0, 0.3])
@pytest.mark.parametrize("model", sorted(CAPILLARY_MODELS))
def test_contact_value_is_limit_from_above(model, theta):
    mid = CAPILLARY_MODELS[model]
    at_contact = capillary_force_scalar(mid, 0.0, V_B, R, GAMMA, theta)
    assert at_contact > 0.0
    assert capillary_force_scalar(mid, -1e-6, V_B, R, GAMMA, theta) == at_contact
    gaps = R * np.array([1e-4, 1e-6, 1e-8, 1e-10])
    diffs = np.abs([capillary_force_scalar(mid, s, V_B, R, GAMMA, theta) - at_contact for s in gaps])
    assert np.all(np.diff(diffs) <= 0.0)
    assert diffs[-1] <= 1e-6 * at_contact


@pytest.mark.parametrize("model", ["willett_analytic", "lambert"])
def test_contact_value_closed_form(model):
    theta = 0.3
    got = capillary_force_scalar(CAPILLARY_MODELS[model], 0.0, V_B, R, GAMMA, theta)
    assert got == pytest.approx(2 * math.pi * R * GAMMA * math.cos(theta), rel=1e-14)


def test_rabinovich_contact_value_closed_form():
    # s → 0⁺ of the formula ("Capillary models"): s/(2 d_sp) → 0 and α² = (s/R)(−1 + √(1 + 2V/(πRs²))) → √(2V/(πR))/R
    theta = 0.3
    alpha0 = (2 * V_B / (math.pi * R**3)) ** 0.25
    want = 2 * math.pi * R * GAMMA * (math.cos(theta) + math.sin(alpha0) * math.sin(theta + alpha0))
    got = capillary_force_scalar(CAPILLARY_MODELS["rabinovich"], 0.0, V_B, R, GAMMA, theta)
    assert got == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize("model", sorted(CAPILLARY_MODELS))
@pytest.mark.parametrize("s", [-1e-6, 0.0, 1e-5])
@pytest.mark.parametrize("v_b", [0.0, -1e-15])
def test_no_liquid_no_force(model, s, v_b):
    assert capillary_force_scalar(CAPILLARY_MODELS[model], s, v_b, R, GAMMA, 0.0) == 0.0


def test_no_liquid_no_rupture_distance():
    assert rupture_distance_scalar(0.0, R, 0.0) == 0.0
    assert rupture_distance_scalar(-1e-15, R, 0.5) == 0.0


def test_callable_from_numba_kernel():
    @njit
    def kernel(model, gaps):
        total = 0.0
        for s in gaps:
            total += capillary_force_scalar(model, s, 1e-12, 0.75e-3, 0.1095, 0.0)
        return total + rupture_distance_scalar(1e-12, 0.75e-3, 0.0)

    gaps = np.array(SPEC_GAPS)
    mid = CAPILLARY_MODELS["willett_numeric"]
    want = sum(capillary_force_scalar(mid, s, V_B, R, GAMMA, 0.0) for s in gaps)
    assert kernel(mid, gaps) == pytest.approx(want + rupture_distance_scalar(V_B, R, 0.0), rel=1e-14)


# --- viscous force -----------------------------------------------------------------------------

ETA = 1.5e-3  # Pa s


def _pitois(eta, r_star, v_n, s, v_b):
    return (6 * math.pi * eta * r_star**2 * v_n / s
            * (1 - 1 / math.sqrt(1 + 2 * v_b / (math.pi * r_star * s**2))) ** 2)


def test_viscous_closed_form():
    r_i, r_j, v_n, s = 0.6e-3, 0.9e-3, 0.03, 2e-5
    r_star = r_i * r_j / (r_i + r_j)
    want = _pitois(ETA, r_star, v_n, s, V_B)
    assert viscous_force(ETA, r_i, r_j, v_n, s, V_B) == pytest.approx(want, rel=1e-12)


def test_viscous_wall_uses_particle_radius():
    v_n, s = 0.03, 2e-5
    want = _pitois(ETA, R, v_n, s, V_B)
    assert viscous_force(ETA, R, math.inf, v_n, s, V_B) == pytest.approx(want, rel=1e-12)


def test_viscous_sign_and_proportionality():
    f = viscous_force(ETA, R, R, 0.02, 1e-5, V_B)
    assert f > 0.0  # approaching: pushes apart
    assert viscous_force(ETA, R, R, -0.02, 1e-5, V_B) == -f
    assert viscous_force(ETA, R, R, 0.06, 1e-5, V_B) == pytest.approx(3 * f, rel=1e-14)
    assert viscous_force(4 * ETA, R, R, 0.02, 1e-5, V_B) == pytest.approx(4 * f, rel=1e-14)
    assert viscous_force(ETA, R, R, 0.0, 1e-5, V_B) == 0.0


def test_viscous_gap_floor():
    r_star = R / 2
    floor = 1e-3 * r_star
    at_floor = viscous_force(ETA, R, R, 0.02, floor, V_B)
    assert at_floor == pytest.approx(_pitois(ETA, r_star, 0.02, floor, V_B), rel=1e-12)
    for s in (0.5 * floor, 1e-9 * floor, 0.0, -1e-6):
        assert viscous_force(ETA, R, R, 0.02, s, V_B) == at_floor
    above = 2 * floor
    assert viscous_force(ETA, R, R, 0.02, above, V_B) == pytest.approx(
        _pitois(ETA, r_star, 0.02, above, V_B), rel=1e-12)
    assert viscous_force(ETA, R, R, 0.02, above, V_B) < at_floor


def test_viscous_no_liquid():
    assert viscous_force(ETA, R, R, 0.02, 1e-5, 0.0) == 0.0


# --- vectorised helper -------------------------------------------------------------------------

def test_curve_matches_scalar_and_broadcasts():
    gaps = np.linspace(0.0, 5e-5, 7)
    volumes = np.array([[1e-12], [1e-11]])
    got = capillary_force_curve("rabinovich", gaps, volumes, R, GAMMA, 0.2)
    assert got.shape == (2, 7)
    mid = CAPILLARY_MODELS["rabinovich"]
    want = [[capillary_force_scalar(mid, s, v, R, GAMMA, 0.2) for s in gaps] for v in volumes[:, 0]]
    np.testing.assert_array_equal(got, want)


def test_curve_unknown_model():
    with pytest.raises(ValueError, match=r"'weigert'.*willett_numeric.*lambert"):
        capillary_force_curve("weigert", [1e-5], V_B, R, GAMMA)


def test_scalar_unknown_model_id():
    with pytest.raises(ValueError):
        capillary_force_scalar(len(CAPILLARY_MODELS), 1e-5, V_B, R, GAMMA, 0.0)


def test_public_vectorised_force_laws_match_yade_and_vanish_beyond_rupture():
    import sim

    path = Path(__file__).resolve().parent / "data" / "yade_capillary_equal_spheres.csv"
    table = pd.read_csv(path)
    names = {"Willett_numeric": "willett_numeric", "Willett_analytic": "willett_analytic", "Rabinovich": "rabinovich", "Lambert": "lambert"}
    rows = table[table.capillary_type.isin(names)]
    for yade_name, group in rows.groupby("capillary_type"):
        f = sim.capillary_force(group.gap_m.to_numpy(), group.r1_m.to_numpy(), group.r2_m.to_numpy(),
                                group.bridge_volume_m3.to_numpy(), group.surface_tension_N_per_m.to_numpy(),
                                group.contact_angle_rad.to_numpy(), model=names[yade_name])
        active = group.bridge_active.to_numpy() == 1
        np.testing.assert_allclose(f[active], group.attractive_force_N.to_numpy()[active], rtol=1e-6)
        assert (f[~active] == 0).all()
    s_crit = sim.rupture_distance(rows.bridge_volume_m3.to_numpy(), rows.r1_m.to_numpy(), rows.r2_m.to_numpy(), 0.0)
    np.testing.assert_allclose(s_crit, rows.yade_s_crit_m.to_numpy(), rtol=1e-6)
    assert sim.rupture_distance(1e-12, 0.5e-3, 1.0e-3, 0.0) == pytest.approx(1.0150e-4, rel=1e-4)
    assert sim.scale_parameters(sim.SimParams(), 2.0).surface_tension == pytest.approx(2 * 0.1095)


def test_willett_numeric_stays_bounded_for_tiny_bridges():
    # migration can leave bridges of ~1e-24 m³; Willett's fit alone gives ~1e3 N there
    r, gamma = 1.1e-3, 0.3285
    for v in (1e-24, 1e-18, 1e-14, 1e-12, 3e-11):
        for s in (0.0, 1e-9, 1e-7):
            f = capillary_force_scalar(CAPILLARY_MODELS["willett_numeric"], s, v, r, gamma, 0.0)
            assert 0.0 <= f <= 2 * math.pi * r * gamma
    assert capillary_force_scalar(CAPILLARY_MODELS["willett_numeric"], 0.0, 1e-24, r, gamma, 0.0) == pytest.approx(2 * math.pi * r * gamma)


@njit(cache=True)
def _bridge_table_vs_direct(model, gaps, volumes, radii, gamma, theta, out):
    """For every (gap, volume, radius): the engine's per-step values from a bridge-constants row
    (force and s_crit) beside the direct formulas."""
    table = np.zeros((1, 8))
    for q in range(gaps.shape[0]):
        bridge_constants(model, volumes[q], radii[q], gamma, theta, table, 0)
        out[q, 0] = bridge_force_from_constants(model, gaps[q], volumes[q], radii[q], gamma, theta, table, 0)
        out[q, 1] = bridge_force(model, gaps[q], volumes[q], radii[q], gamma, theta)
        out[q, 2] = table[0, 1]
        out[q, 3] = rupture_distance_scalar(volumes[q], radii[q], theta)


@pytest.mark.parametrize("model", sorted(CAPILLARY_MODELS))
@pytest.mark.parametrize("theta", [0.0, 0.3])
def test_bridge_constants_give_the_direct_force_bit_for_bit(model, theta):
    """The engine computes a bridge's volume-dependent constants once per volume (the bridge
    table); force and rupture distance from them must equal the direct formulas exactly, at
    contact, across the gap range and for migration's tiny leftover volumes (capped range)."""
    rng = np.random.default_rng(3)
    n = 4000
    radii = rng.uniform(0.5e-3, 2.5e-3, n)
    volumes = 10.0 ** rng.uniform(-24, -10, n)
    s_crit = np.array([rupture_distance_scalar(v, r, theta) for v, r in zip(volumes, radii)])
    gaps = np.where(rng.random(n) < 0.2, -rng.uniform(0, 1e-5, n), rng.uniform(0, 1.0, n) * s_crit)
    gaps[:10] = 0.0
    out = np.empty((n, 4))
    _bridge_table_vs_direct(CAPILLARY_MODELS[model], gaps, volumes, radii, GAMMA, theta, out)
    assert np.array_equal(out[:, 0], out[:, 1])
    assert np.array_equal(out[:, 2], out[:, 3])
    assert (out[gaps <= 0, 0] > 0).all() and (out[:, 0] >= 0).all()
