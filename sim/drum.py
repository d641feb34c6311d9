"""Analytic drum walls (the study's baffled drum; docs/simulator.md): a cylinder of radius R_d about the z axis, radial
baffles of height h = baffle_height·R_d rotating with the drum, and flat end plates at z = 0 and
z = L. Walls are infinitely massive bodies; their surface velocity at a point c is Ω ẑ × c.

Wall index w: 0 = cylinder, 1 … n_baffles = baffles, then the end plates z = 0 and z = L.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["n_walls", "wall_contact", "baffle_directions", "facet_reach"]


def n_walls(n_baffles: int) -> int:
    """Number of wall bodies of a drum with ``n_baffles`` baffles."""
    return 1 + n_baffles + 2


@njit(cache=True)
def baffle_directions(n_baffles, angle, out):
    """Unit radial direction (cos φ_b, sin φ_b) of every baffle at drum angle ``angle`` [rad],
    φ_b = angle + 2πb/n_baffles, written to ``out[:n_baffles]``, and the drum's own
    (cos angle, sin angle) to ``out[n_baffles]`` (the facet polygon's first vertex):
    ``out`` is (n_baffles + 1, 2)."""
    for b in range(n_baffles):
        phi = angle + 2.0 * math.pi * b / n_baffles
        out[b, 0] = math.cos(phi)
        out[b, 1] = math.sin(phi)
    out[n_baffles, 0] = math.cos(angle)
    out[n_baffles, 1] = math.sin(angle)


@njit(cache=True)
def facet_reach(drum_radius, cylinder_facets):
    """The radius [m] inside which a particle surely misses the cylinder: R_d for the smooth
    one, the inradius R_d·cos(π/N) of an N-facet polygon less 1e-9 R_d (rounding) for a polygon."""
    if cylinder_facets == 0:
        return drum_radius
    return drum_radius * math.cos(math.pi / cylinder_facets) - 1e-9 * drum_radius


@njit(cache=True, inline="always")
def wall_contact(w, px, py, pz, radius, drum_radius, drum_length, n_baffles, baffle_height, cylinder_facets, omega,
                 baffle_dir):
    """Geometry of a particle (centre p, radius) against wall w; ``baffle_dir`` holds the
    baffles' and the drum's current directions (:func:`baffle_directions`). With
    ``cylinder_facets`` N >= 3 the cylinder is the polygon of N flat facets whose vertices lie on
    R_d at the drum's angle + 2πk/N (YADE's ``facetCylinder``); a particle meets the facet of
    the sector its centre lies in (one contact: where YADE also touches the neighbouring facet
    in the thin wedge beside a vertex, this model does not).

    Returns
    -------
    ok : bool
        False for degenerate geometry (centre exactly on the axis or on a plate).
    nx, ny, nz : float
        Unit normal from the particle towards the wall.
    u : float
        Overlap radius − distance [m] (negative: gap).
    wx, wy : float
        Wall surface velocity at the closest point [m/s] (z component is 0).
    """
    if w == 0 and cylinder_facets > 0:  # facet polygon turning with the drum
        ax, ay = baffle_dir[n_baffles, 0], baffle_dir[n_baffles, 1]
        sector = 2.0 * math.pi / cylinder_facets
        psi = math.atan2(py * ax - px * ay, px * ax + py * ay)  # the centre's angle from the first vertex
        k = math.floor(psi / sector)
        phi = (k + 0.5) * sector  # the facet's normal, from the first vertex
        ex, ey = ax * math.cos(phi) - ay * math.sin(phi), ay * math.cos(phi) + ax * math.sin(phi)
        depth = drum_radius * math.cos(0.5 * sector) - (px * ex + py * ey)  # centre to the facet's plane
        nx, ny, nz = ex, ey, 0.0
        u = radius - depth
        cx, cy = px + depth * ex, py + depth * ey
    elif w == 0:  # cylinder
        r = math.sqrt(px * px + py * py)
        if r == 0.0:
            return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        nx, ny, nz = px / r, py / r, 0.0
        u = r + radius - drum_radius
        cx, cy = drum_radius * nx, drum_radius * ny
    elif w <= n_baffles:  # thin radial plate
        ex, ey = baffle_dir[w - 1, 0], baffle_dir[w - 1, 1]
        a = px * ex + py * ey  # radial coordinate along the plate
        b = -px * ey + py * ex  # signed distance from the plate's plane
        inner = drum_radius * (1.0 - baffle_height)
        if a >= inner:
            if b == 0.0:
                return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            # towards the plate: −sign(b)·e⊥ with e⊥ = (−e_y, e_x)
            sign = 1.0 if b > 0.0 else -1.0
            nx, ny, nz = sign * ey, -sign * ex, 0.0
            u = radius - abs(b)
            cx, cy = a * ex, a * ey
        else:  # the plate's inner edge
            cx, cy = inner * ex, inner * ey
            dx, dy = cx - px, cy - py
            dist = math.sqrt(dx * dx + dy * dy)
            if dist == 0.0:
                return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            nx, ny, nz = dx / dist, dy / dist, 0.0
            u = radius - dist
    else:  # end plates
        nx, ny = 0.0, 0.0
        if w == n_baffles + 1:
            nz = -1.0
            u = radius - pz
        else:
            nz = 1.0
            u = radius - (drum_length - pz)
        cx, cy = px, py
    return True, nx, ny, nz, u, -omega * cy, omega * cx
