"""The drum's walls: the facet polygon that stands in for YADE's ``facetCylinder``."""

import math

import numpy as np
import pytest

from sim.drum import baffle_directions, facet_reach, wall_contact

R_D, LENGTH, N_BAFFLES, HEIGHT = 0.1, 0.05, 4, 0.15


def _cylinder(p, radius, facets, angle):
    directions = np.empty((N_BAFFLES + 1, 2))
    baffle_directions(N_BAFFLES, angle, directions)
    return wall_contact(0, p[0], p[1], 0.02, radius, R_D, LENGTH, N_BAFFLES, HEIGHT, facets, 1.5, directions)


@pytest.mark.parametrize("angle", [0.0, 0.3, -2.0])
def test_a_particle_meets_the_facet_of_its_sector_at_the_polygons_inradius(angle):
    facets, radius = 12, 0.004
    sector = 2 * math.pi / facets
    inradius = R_D * math.cos(sector / 2)
    for k, offset in [(0, 0.5), (3, 0.5), (7, 0.1), (11, 0.9)]:
        phi = angle + (k + offset) * sector  # the centre's direction
        rho = inradius - radius + 1e-4  # overlapping the facet by 1e-4 m at its middle
        p = (rho * math.cos(phi), rho * math.sin(phi))
        ok, nx, ny, nz, u, wx, wy = _cylinder(p, radius, facets, angle)
        normal = angle + (k + 0.5) * sector  # the facet's outward normal
        assert ok and nz == 0.0
        assert (nx, ny) == pytest.approx((math.cos(normal), math.sin(normal)), abs=1e-12)
        # overlap = radius − (inradius − p·n)
        assert u == pytest.approx(radius - (inradius - rho * math.cos(phi - normal)), abs=1e-15)
        # the wall's surface velocity at the contact point c = p + depth·n is Ω ẑ × c
        depth = radius - u
        c = (p[0] + depth * nx, p[1] + depth * ny)
        assert (wx, wy) == pytest.approx((-1.5 * c[1], 1.5 * c[0]), abs=1e-15)


def test_the_smooth_cylinder_is_unchanged_and_the_polygon_lies_inside_it():
    radius, rho, phi = 0.004, 0.0965, 0.4
    p = (rho * math.cos(phi), rho * math.sin(phi))
    ok, nx, ny, _, u, _, _ = _cylinder(p, radius, 0, 0.0)
    assert ok and u == pytest.approx(rho + radius - R_D, abs=1e-15)
    assert (nx, ny) == pytest.approx((math.cos(phi), math.sin(phi)))
    for facets in (3, 12, 96):
        u_polygon = _cylinder(p, radius, facets, 0.0)[4]
        assert u_polygon >= u  # the polygon's facets lie inside the circle through its vertices
        assert facet_reach(R_D, facets) < R_D * math.cos(math.pi / facets)
    assert facet_reach(R_D, 0) == R_D


def test_a_particle_inside_the_reach_never_touches_any_facet():
    rng = np.random.default_rng(0)
    for facets in (3, 7, 96):
        reach = facet_reach(R_D, facets)
        for _ in range(200):
            radius = rng.uniform(1e-3, 5e-3)
            rho, phi, angle = rng.uniform(0.5, 1.0) * (reach - radius), rng.uniform(-math.pi, math.pi), rng.uniform(-7, 7)
            assert _cylinder((rho * math.cos(phi), rho * math.sin(phi)), radius, facets, angle)[4] < 0.0


def test_a_short_run_in_a_polygon_drum_keeps_every_particle_inside_the_polygon():
    import dataclasses

    from conftest import former_lab_original
    from sim.params import cg_scale
    from sim.run import Simulation

    facets = 8  # coarse, so that the polygon lies far inside the circle (inradius 0.924 R_d)
    params = dataclasses.replace(cg_scale(former_lab_original(5400), 3.0), settle_time=0.02, cylinder_facets=facets)
    sim = Simulation(params, former_lab_original(5400))
    sim.advance(int(round(0.05 / params.dt)))
    angle = params.drum_omega * sim.state.step * params.dt  # the polygon's first vertex
    pos, radius = sim.state.pos, sim.state.radius
    sector = 2 * math.pi / facets
    psi = np.arctan2(pos[:, 1], pos[:, 0]) - angle
    normal = angle + (np.floor(psi / sector) + 0.5) * sector
    depth = params.drum_radius * math.cos(sector / 2) - (pos[:, 0] * np.cos(normal) + pos[:, 1] * np.sin(normal))
    assert np.all(depth >= 0.9 * radius)  # no particle is through a facet (contact overlaps are < 10 % of r)
    near = depth < 1.05 * radius
    assert near.sum() >= 5  # ... and the bed lies on the facets (in a smooth drum of R_d, depth would reach r − 0.076 R_d)
