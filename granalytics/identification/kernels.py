"""Numba kernels (private). Every kernel here has a readable reference it is tested against:
the GNA filter against a NumPy/arccos implementation, union-find against networkx BFS."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from granalytics.base.sorting import counting_sort


@njit(cache=True, inline="always")
def _angle_below(ax, ay, az, bx, by, bz, cos_a):
    """True when the angle between a and b is strictly below A (cos_a = cos A), without arccos.

    angle < A  ⇔  a·b > cos A·|a||b|; squared to avoid the square root:
    for A ≤ 90°: a·b > 0 and (a·b)² > cos²A·|a|²|b|²; for A > 90°: a·b ≥ 0 or (a·b)² < cos²A·|a|²|b|².
    A zero vector has no direction: an angle involving it never passes.
    """
    dot = ax * bx + ay * by + az * bz
    norms = (ax * ax + ay * ay + az * az) * (bx * bx + by * by + bz * bz)
    cos2_norms = cos_a * cos_a * norms
    # bitwise & and | instead of and/or: no data-dependent branch (the sign of cos_a is the same
    # for every contact); benchmarks/identify.py measured the filter 1.3-1.7x faster this way
    if cos_a >= 0.0:
        return (norms != 0.0) & (dot > 0.0) & (dot * dot > cos2_norms)
    return (norms != 0.0) & ((dot >= 0.0) | (dot * dot < cos2_norms))


@njit(cache=True, inline="always")
def _pair_radius(radius, i, j, mean_radius):
    """Radius R in F_max = 2πγR: the pair's R* = 2RiRj/(Ri+Rj), or mean_radius when > 0."""
    if mean_radius > 0.0:
        return mean_radius
    ri = radius[i]
    rj = radius[j]
    return 2.0 * ri * rj / (ri + rj)


@njit(cache=True, inline="always")
def _keep_contact(k, ci, cj, f_cap, gap, all_count, radius, vel, omega, two_pi_gamma, mean_radius, c_agg, cos_a):
    """Both GNA criteria for contact k. F_coh is ``f_cap[k]`` where the cohesion convention counts
    it (every contact with ``all_count``, else those with ``gap[k] > 0``) and 0 elsewhere: the
    values of :func:`granalytics.cohesive_force`, without building that array."""
    i = ci[k]
    j = cj[k]
    f_coh = f_cap[k] if all_count or gap[k] > 0.0 else 0.0
    f_norm = f_coh / (two_pi_gamma * _pair_radius(radius, i, j, mean_radius))
    # both angles are always evaluated: cheaper than a mispredicted branch
    return (f_norm >= c_agg) & (
        _angle_below(vel[i, 0], vel[i, 1], vel[i, 2], vel[j, 0], vel[j, 1], vel[j, 2], cos_a)
        | _angle_below(omega[i, 0], omega[i, 1], omega[i, 2], omega[j, 0], omega[j, 1], omega[j, 2], cos_a)
    )


@njit(cache=True, parallel=True)
def gna_contact_mask(ci, cj, f_cap, gap, all_count, radius, vel, omega, two_pi_gamma, mean_radius, c_agg, cos_a):
    """Boolean mask of the contacts that pass both GNA criteria (§2.2 of the paper); F_coh as in
    :func:`_keep_contact`.

    Each entry depends on its own contact only, so the parallel loop is deterministic.
    """
    m = ci.shape[0]
    keep = np.empty(m, dtype=np.bool_)
    for k in prange(m):
        keep[k] = _keep_contact(
            k, ci, cj, f_cap, gap, all_count, radius, vel, omega, two_pi_gamma, mean_radius, c_agg, cos_a
        )
    return keep


@njit(cache=True, nogil=True)
def contact_strength(ci, cj, f_cap, radius, two_pi_gamma, mean_radius):
    """f = F_coh / (2πγR) per contact, the same arithmetic as :func:`_keep_contact`."""
    m = ci.shape[0]
    out = np.empty(m)
    for k in range(m):
        out[k] = f_cap[k] / (two_pi_gamma * _pair_radius(radius, ci[k], cj[k], mean_radius))
    return out


@njit(cache=True, nogil=True)
def co_moving(ci, cj, vel, omega, cos_a):
    """The co-motion criterion per contact, the same arithmetic as :func:`_keep_contact`."""
    m = ci.shape[0]
    out = np.empty(m, dtype=np.bool_)
    for k in range(m):
        i = ci[k]
        j = cj[k]
        out[k] = _angle_below(vel[i, 0], vel[i, 1], vel[i, 2], vel[j, 0], vel[j, 1], vel[j, 2], cos_a) or \
            _angle_below(omega[i, 0], omega[i, 1], omega[i, 2], omega[j, 0], omega[j, 1], omega[j, 2], cos_a)
    return out


@njit(cache=True, nogil=True)
def rigid_residual(ci, cj, pos, vel, omega):
    """Non-rigid relative velocity of every contact [m/s]: |v_j − v_i − ω̄ × (r_j − r_i)| with
    ω̄ = (ω_i + ω_j)/2; 0 for two particles moving as one rigid body (in particular the drum's
    solid-body rotation)."""
    m = ci.shape[0]
    out = np.empty(m)
    for k in range(m):
        i = ci[k]
        j = cj[k]
        dx = pos[j, 0] - pos[i, 0]
        dy = pos[j, 1] - pos[i, 1]
        dz = pos[j, 2] - pos[i, 2]
        wx = 0.5 * (omega[i, 0] + omega[j, 0])
        wy = 0.5 * (omega[i, 1] + omega[j, 1])
        wz = 0.5 * (omega[i, 2] + omega[j, 2])
        ux = vel[j, 0] - vel[i, 0] - (wy * dz - wz * dy)
        uy = vel[j, 1] - vel[i, 1] - (wz * dx - wx * dz)
        uz = vel[j, 2] - vel[i, 2] - (wx * dy - wy * dx)
        out[k] = np.sqrt(ux * ux + uy * uy + uz * uz)
    return out


@njit(cache=True, inline="always")
def _find(parent, i):
    """Root of i, with path halving."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True, inline="always")
def _link(parent, a, b):
    """Join the distinct roots a and b: the smaller index becomes the root. Returns (root, other)."""
    if a < b:
        parent[b] = a
        return a, b
    parent[a] = b
    return b, a


@njit(cache=True, inline="always")
def _union(parent, i, j):
    """Merge the sets of i and j; the smaller root index becomes the root."""
    ri = _find(parent, i)
    rj = _find(parent, j)
    if ri == rj:
        return False
    _link(parent, ri, rj)
    return True


@njit(cache=True, inline="always")
def _merge_order(f, passes):
    """The contacts that pass the co-motion test, in decreasing f (stable): the order in which the
    threshold sweeps merge them."""
    idx = np.flatnonzero(passes)
    return idx[np.argsort(-f[idx], kind="mergesort")]


@njit(cache=True, inline="always")
def _next_merge(parent, ci, cj, f, order, p, c):
    """The next contact of ``order`` from position ``p`` with f ≥ ``c`` that joins two granules:
    returns ``(p after it, root a, root b)``, or ``(p, -1, -1)`` when no such contact is left."""
    while p < order.shape[0] and f[order[p]] >= c:
        k = order[p]
        p += 1
        a = _find(parent, ci[k])
        b = _find(parent, cj[k])
        if a != b:
            return p, a, b
    return p, -1, -1


@njit(cache=True)
def _rank_by_size(comp_size):
    """Rank of each component when ordered by decreasing size, ties in index order (a stable
    counting sort, O(G + largest size)); returns ``(rank, sizes in rank order)``."""
    n_comp = comp_size.shape[0]
    largest = 0
    for c in range(n_comp):
        largest = max(largest, comp_size[c])
    order, _ = counting_sort(largest - comp_size, largest + 1)  # key largest − size: largest first
    rank = np.empty(n_comp, dtype=np.int64)
    sizes = np.empty(n_comp, dtype=np.int64)
    for p in range(n_comp):
        rank[order[p]] = p
        sizes[p] = comp_size[order[p]]
    return rank, sizes


@njit(cache=True)
def canonical_labels(membership):
    """Deterministic granule labels from any component membership.

    Parameters
    ----------
    membership : (N,) int64 array
        Component id of each particle, each id in [0, N).

    Returns
    -------
    labels : (N,) int64 array
        −1 for particles alone in their component; granules numbered 0, 1, … by decreasing size,
        ties broken by the smallest particle index in the granule.
    sizes : (G,) int64 array
        Particle count of granule g at ``sizes[g]``.
    """
    n = membership.shape[0]
    size = np.zeros(n, dtype=np.int64)
    for i in range(n):
        size[membership[i]] += 1
    comp_of = np.full(n, -1, dtype=np.int64)
    comp_size = np.empty(n, dtype=np.int64)
    n_comp = 0
    for i in range(n):  # index order: a component is first met at its smallest member
        c = membership[i]
        if size[c] >= 2 and comp_of[c] < 0:
            comp_of[c] = n_comp
            comp_size[n_comp] = size[c]
            n_comp += 1
    rank, sizes = _rank_by_size(comp_size[:n_comp])
    labels = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        c = comp_of[membership[i]]
        if c >= 0:
            labels[i] = rank[c]
    return labels, sizes


@njit(cache=True)
def union_find_membership(n, ei, ej):
    """Component root of every node of the graph with edges (ei[k], ej[k])."""
    parent = np.arange(n)
    for k in range(ei.shape[0]):
        _union(parent, ei[k], ej[k])
    for i in range(n):
        parent[i] = _find(parent, i)
    return parent


@njit(cache=True)
def merge_and_label(n, ci, cj, keep):
    """Union-find over the kept contacts, in contact order, then the labels and sizes of
    :func:`canonical_labels` in two passes over the particles."""
    parent = np.arange(n)
    for k in range(ci.shape[0]):
        if keep[k]:
            _union(parent, ci[k], cj[k])
    # _union keeps the smaller index as root and path halving only moves a node to a smaller
    # ancestor, so parent[i] <= i: in index order every parent is already resolved to its root
    # (the smallest member), and one pass gives roots and sizes; a second numbers components
    # in order of their smallest member, as canonical_labels does.
    size = np.zeros(n, dtype=np.int64)
    for i in range(n):
        root = parent[parent[i]]
        parent[i] = root
        size[root] += 1
    comp_size = np.empty(n, dtype=np.int64)
    labels = np.empty(n, dtype=np.int64)
    n_comp = 0
    for i in range(n):
        root = parent[i]
        if root == i:
            if size[i] >= 2:
                comp_size[n_comp] = size[i]
                size[i] = -(n_comp + 1)  # from here on: the component's number, encoded
                n_comp += 1
            else:
                size[i] = 0
        c = size[root]
        labels[i] = -c - 1 if c < 0 else -1
    rank, sizes = _rank_by_size(comp_size[:n_comp])
    for i in range(n):
        if labels[i] >= 0:
            labels[i] = rank[labels[i]]
    return labels, sizes


@njit(cache=True)
def gna_fused(ci, cj, f_cap, gap, all_count, radius, vel, omega, two_pi_gamma, mean_radius, c_agg, cos_a):
    """Filter (parallel over contacts), union-find and canonical labelling in one compiled call
    (the ``"fast"`` backend).

    The sequential merge lives in its own non-parallel kernel: inside a ``parallel=True``
    function numba compiled it about twice slower.

    Returns
    -------
    labels, sizes : as :func:`canonical_labels`
    keep : (M,) bool array
        Contacts that passed both criteria.
    """
    keep = gna_contact_mask(ci, cj, f_cap, gap, all_count, radius, vel, omega, two_pi_gamma, mean_radius, c_agg, cos_a)
    labels, sizes = merge_and_label(radius.shape[0], ci, cj, keep)
    return labels, sizes, keep


@njit(cache=True)
def principal_extents(membership, n_groups, pos, radius, weight):
    """Extents of every group of spheres along its principal axes, largest first.

    The axes are the eigenvectors of the weight-averaged gyration tensor of the centres; the
    extent along axis e is max(p·e + R) − min(p·e − R) over the group's spheres.

    Returns
    -------
    (n_groups, 3) float array [m].
    """
    order, start = counting_sort(membership, n_groups)
    out = np.empty((n_groups, 3))
    gyr = np.empty((3, 3))
    for g in range(n_groups):
        a, b = start[g], start[g + 1]
        w = 0.0
        c = np.zeros(3)
        for q in range(a, b):
            i = order[q]
            w += weight[i]
            for d in range(3):
                c[d] += weight[i] * pos[i, d]
        c /= w
        gyr[:, :] = 0.0
        for q in range(a, b):
            i = order[q]
            for d in range(3):
                for e in range(3):
                    gyr[d, e] += weight[i] * (pos[i, d] - c[d]) * (pos[i, e] - c[e])
        gyr /= w
        _, vecs = np.linalg.eigh(gyr)
        for k in range(3):
            lo = np.inf
            hi = -np.inf
            for q in range(a, b):
                i = order[q]
                p = pos[i, 0] * vecs[0, k] + pos[i, 1] * vecs[1, k] + pos[i, 2] * vecs[2, k]
                lo = min(lo, p - radius[i])
                hi = max(hi, p + radius[i])
            out[g, k] = hi - lo
        out[g] = np.sort(out[g])[::-1]
    return out


@njit(cache=True, nogil=True)
def threshold_sweep(ci, cj, f, passes, particle_volume, thresholds_desc, min_size=2):
    """Granule statistics at every cohesion threshold in one pass (Newman & Ziff 2000).

    Contacts that pass the angle criterion are merged with union-find in decreasing order of
    f = F_coh/(2πγR); after all contacts with f ≥ c have been merged, the partition is exactly
    GNA's at C_agg = c, and its statistics are recorded.

    Parameters
    ----------
    ci, cj : contact particle indices
    f : normalised capillary force per contact
    passes : bool per contact, the co-motion criterion
    particle_volume : (N,) [m³]
    thresholds_desc : C_agg values in decreasing order
    min_size : fewest particles of a counted granule (>= 2)

    Returns
    -------
    n_granules, n_granulated : (T,) int64
    volume_granulated : (T,) float64 [m³]
    """
    n = particle_volume.shape[0]
    order = _merge_order(f, passes)
    parent = np.arange(n)
    size = np.ones(n, dtype=np.int64)
    vol = particle_volume.copy()
    t_count = thresholds_desc.shape[0]
    n_gran = np.zeros(t_count, dtype=np.int64)
    n_in = np.zeros(t_count, dtype=np.int64)
    v_in = np.zeros(t_count)
    granules = 0
    members = 0
    volume = 0.0
    p = 0
    for t in range(t_count):
        while True:
            p, a, b = _next_merge(parent, ci, cj, f, order, p, thresholds_desc[t])
            if a < 0:
                break
            sa, sb = size[a], size[b]
            va, vb = vol[a], vol[b]
            if sa >= min_size:
                granules -= 1
                members -= sa
                volume -= va
            if sb >= min_size:
                granules -= 1
                members -= sb
                volume -= vb
            root = _link(parent, a, b)[0]
            size[root] = sa + sb
            vol[root] = va + vb
            if sa + sb >= min_size:
                granules += 1
                members += sa + sb
                volume += va + vb
        n_gran[t] = granules
        n_in[t] = members
        v_in[t] = volume
    return n_gran, n_in, v_in


@njit(cache=True)
def class_volumes(gid, n_groups, dirty, cache_size, particle_volume, free_size, position, radius, edges, measure):
    """Solid volume of the particles in every size class, for one partition into granules.

    A granule's sieve size is, by ``measure``: 0, the diameter of the sphere of its solid volume
    (6V/π)^(1/3); 1, its second-largest principal extent (:func:`principal_extents`, the width a
    square aperture sees). A free particle's size is ``free_size``. Sizes are binned on ``edges``
    (ascending apertures [m]): bin 0 below ``edges[0]``, bin k in [edges[k-1], edges[k]), the last
    bin at or above ``edges[-1]``; a grain passes an aperture when its size is smaller.

    Parameters
    ----------
    gid : (N,) int64
        Granule of every particle, in [0, n_groups), or −1 for a free particle.
    dirty : (n_groups,) bool
        Groups whose size is computed here (written into ``cache_size``); the others' sizes are
        read from ``cache_size`` (the sensitivity sweep recomputes only granules that grew).
    cache_size : (n_groups,) float64 [m]
    particle_volume, free_size : (N,) [m³], [m]
    position, radius : (N, 3), (N,) [m]
    edges : (K+1,) [m]
    measure : int
        0 volume-equivalent diameter, 1 second principal extent.

    Returns
    -------
    (K+2,) float64 [m³]
        Volume per bin, each particle's volume added in particle order (so that two partitions
        that are equal give bit-identical results, whatever computed them).
    """
    n = gid.shape[0]
    if measure == 0:
        gv = np.zeros(n_groups)
        for i in range(n):
            g = gid[i]
            if g >= 0 and dirty[g]:
                gv[g] += particle_volume[i]
        for g in range(n_groups):
            if dirty[g]:
                cache_size[g] = (6.0 * gv[g] / np.pi) ** (1.0 / 3.0)
    else:
        sub = np.full(n_groups, -1, dtype=np.int64)
        nd = 0
        for g in range(n_groups):
            if dirty[g]:
                sub[g] = nd
                nd += 1
        count = 0
        for i in range(n):
            g = gid[i]
            if g >= 0 and dirty[g]:
                count += 1
        idx = np.empty(count, dtype=np.int64)
        memb = np.empty(count, dtype=np.int64)
        q = 0
        for i in range(n):
            g = gid[i]
            if g >= 0 and dirty[g]:
                idx[q] = i
                memb[q] = sub[g]
                q += 1
        if nd > 0:
            ext = principal_extents(memb, nd, position[idx], radius[idx], particle_volume[idx])
            for g in range(n_groups):
                if dirty[g]:
                    cache_size[g] = ext[sub[g], 1]
    hist = np.zeros(edges.shape[0] + 1)
    for i in range(n):
        g = gid[i]
        x = cache_size[g] if g >= 0 else free_size[i]
        hist[np.searchsorted(edges, x, side="right")] += particle_volume[i]
    return hist


@njit(cache=True, nogil=True)
def threshold_sweep_classes(ci, cj, f, passes, particle_volume, free_size, position, radius, thresholds_desc, edges,
                            min_size=2, measure=0):
    """The size distribution of the granules at every cohesion threshold in one pass: the merge of
    :func:`threshold_sweep` (contacts passing the co-motion test joined in decreasing f; after the
    contacts with f ≥ c, the partition is GNA's at C_agg = c) with :func:`class_volumes` recorded
    at each threshold. Only granules that grew since the previous threshold get their size
    computed again.

    Returns
    -------
    (T, K+2) float64 [m³]
        Volume per size bin (:func:`class_volumes`) at each threshold of ``thresholds_desc``.
    """
    n = particle_volume.shape[0]
    order = _merge_order(f, passes)
    parent = np.arange(n)
    size = np.ones(n, dtype=np.int64)
    dirty = np.zeros(n, dtype=np.bool_)
    cache = np.zeros(n)
    gid = np.full(n, -1, dtype=np.int64)
    t_count = thresholds_desc.shape[0]
    out = np.zeros((t_count, edges.shape[0] + 1))
    p = 0
    for t in range(t_count):
        while True:
            p, a, b = _next_merge(parent, ci, cj, f, order, p, thresholds_desc[t])
            if a < 0:
                break
            root, other = _link(parent, a, b)
            size[root] = size[a] + size[b]
            dirty[other] = False  # only roots of granules are ever dirty
            if size[root] >= min_size:
                dirty[root] = True
        for i in range(n):
            r = _find(parent, i)
            gid[i] = r if size[r] >= min_size else -1
        out[t] = class_volumes(gid, n, dirty, cache, particle_volume, free_size, position, radius, edges, measure)
        dirty[:] = False
    return out
