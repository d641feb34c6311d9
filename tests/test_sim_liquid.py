"""Liquid migration and spraying (sim/liquid.py; docs/physics.md, "Liquid bridges", "Spraying",
"Liquid migration").

Expected values are worked out by hand from those rules; volumes are in units of
U = 1e-12 m³ to keep the arithmetic readable.
"""

import math

import numpy as np
import pytest

from sim.liquid import migrate_liquid, spray, total_liquid

U = 1e-12  # m³


def approx(x):
    return pytest.approx(x, rel=1e-12, abs=1e-27)


def build_csr(n_bodies, pair_i, pair_j, rng=None):
    """Slot lists per body (all slots, dead ones included), ascending or randomly permuted."""
    lists = [[] for _ in range(n_bodies)]
    for k, (i, j) in enumerate(zip(pair_i, pair_j)):
        lists[i].append(k)
        lists[j].append(k)
    if rng is not None:
        lists = [list(rng.permutation(lst)) for lst in lists]
    start = np.zeros(n_bodies + 1, dtype=np.int64)
    start[1:] = np.cumsum([len(lst) for lst in lists])
    slots = np.array([k for lst in lists for k in lst], dtype=np.int64)
    return start, slots, lists


class Scene:
    """Arrays of a small hand-built case: ``pairs`` fixes the slots, everything else 0/False."""

    def __init__(self, films, pairs, v_max):
        self.film = np.asarray(films, dtype=np.float64) * U
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        self.pair_i = pairs[:, 0].copy()
        self.pair_j = pairs[:, 1].copy()
        c = len(pairs)
        self.v_b = np.zeros(c)
        self.v_max = np.broadcast_to(np.asarray(v_max, dtype=np.float64) * U, (c,)).copy()
        self.alive = np.zeros(c, dtype=bool)
        self.created = np.zeros(c, dtype=bool)
        self.ruptured = np.zeros(c)
        self.start, self.slots, _ = build_csr(len(self.film), self.pair_i, self.pair_j)

    def bridge(self, k, vol):
        """Slot k is a live bridge of volume vol·U."""
        self.alive[k] = True
        self.v_b[k] = vol * U

    def create(self, k):
        self.alive[k] = True
        self.created[k] = True
        self.v_b[k] = 0.0

    def rupture(self, k, vol):
        """Slot k ruptured this step with volume vol·U (as the force pass leaves it)."""
        self.alive[k] = False
        self.v_b[k] = 0.0
        self.ruptured[k] = vol * U

    def step(self, v_min=0.0):
        before = total_liquid(self.film, self.v_b, self.alive) + self.ruptured.sum()
        migrate_liquid(self.film, self.pair_i, self.pair_j, self.v_b, self.v_max, self.alive,
                       self.created, self.ruptured, self.start, self.slots, v_min, np.arange(self.film.size))
        assert total_liquid(self.film, self.v_b, self.alive) == pytest.approx(before, rel=1e-14, abs=1e-30)
        assert (self.film >= 0).all() and (self.v_b >= 0).all()
        # what the force pass of the next step does first
        self.created[:] = False
        self.ruptured[:] = 0.0


# --------------------------------------------------------------------------- two particles


def test_creation_takes_both_shares():
    s = Scene([3.0, 1.0], [(0, 1)], v_max=100.0)
    s.create(0)
    s.step()
    assert s.v_b[0] == approx(4.0 * U)
    assert s.film == approx(np.array([0.0, 0.0]))


def test_creation_cap_scales_shares_proportionally():
    s = Scene([3.0, 1.0], [(0, 1)], v_max=2.0)
    s.create(0)
    s.step()
    # a = (3, 1), sum 4 > V_max = 2: both shares × 1/2 → withdrawn (1.5, 0.5)
    assert s.v_b[0] == approx(2.0 * U)
    assert s.film == approx(np.array([1.5, 0.5]) * U)


def test_dry_pair_and_one_sided_pair():
    s = Scene([0.0, 0.0, 2.0, 0.0], [(0, 1), (2, 3)], v_max=100.0)
    s.create(0)
    s.create(1)
    s.step()
    assert s.v_b[0] == 0.0
    assert s.alive[0]
    assert s.v_b[1] == approx(2.0 * U)
    assert s.film == approx(np.array([0.0, 0.0, 0.0, 0.0]))


def test_no_events_changes_nothing():
    s = Scene([3.0, 1.0, 0.0], [(0, 1), (1, 2)], v_max=5.0)
    s.bridge(0, 1.0)
    s.bridge(1, 0.0)
    s.step()
    assert s.film == approx(np.array([3.0, 1.0, 0.0]) * U)
    assert s.v_b == approx(np.array([1.0, 0.0]) * U)


# --------------------------------------------------------------------------- three particles


def test_two_new_bridges_split_film_read_before_withdrawal():
    # body 1 forms (1,2) and (0,1) in the same step; slot order puts (1,2) first
    s = Scene([1.0, 4.0, 0.0], [(1, 2), (0, 1)], v_max=[10.0, 2.5])
    s.create(0)
    s.create(1)
    s.step()
    # n_new(1) = 2 → a_1 = 4/2 = 2 for both (film read before any withdrawal); a_0 = 1, a_2 = 0
    # (1,2): 2 + 0 = 2 ≤ 10.  (0,1): 1 + 2 = 3 > 2.5 → shares × 2.5/3 = (5/6, 5/3)
    assert s.v_b == approx(np.array([2.0, 2.5]) * U)
    assert s.film == approx(np.array([1.0 - 5.0 / 6.0, 4.0 - 2.0 - 5.0 / 3.0, 0.0]) * U)


# --------------------------------------------------------------------------- four particles


def test_rupture_returns_half_and_refills_only_marked_bodies():
    # chain 0-1-2-3; (0,1) ruptures with 4U
    s = Scene([0.0, 0.0, 2.0, 0.0], [(0, 1), (1, 2), (2, 3)], v_max=5.0)
    s.rupture(0, 4.0)
    s.bridge(1, 1.0)
    s.bridge(2, 0.0)
    s.step()
    # step 1: films (2, 2, 2, 0), marked {0, 1}
    # body 0: no live bridge, keeps 2.  body 1: A = 2, D = 5 − 1 = 4 > A → (1,2) += 4·2/4
    # body 2 is not marked: (2,3) stays dry although body 2 holds film
    assert s.film == approx(np.array([2.0, 0.0, 2.0, 0.0]) * U)
    assert s.v_b == approx(np.array([0.0, 3.0, 0.0]) * U)
    assert not s.alive[0]


def test_refill_both_cases_in_ascending_body_order():
    pairs = [(0, 3), (1, 2), (0, 1), (1, 3), (2, 3)]
    s = Scene([0.0, 0.5, 0.5, 1.0], pairs, v_max=5.0)
    s.rupture(0, 6.0)
    s.rupture(1, 2.0)
    s.bridge(2, 1.0)
    s.bridge(3, 0.0)
    s.bridge(4, 4.0)
    s.step()
    # step 1: films (3, 1.5, 1.5, 4), all four marked
    # body 0: A = 3; (0,1) D = 4 > A → (0,1) = 1 + 4·3/4 = 4, film 0
    # body 1: A = 1.5; (0,1) 1, (1,3) 5 → D = 6 > A, fill 1/4 → (0,1) = 4.25, (1,3) = 1.25, film 0
    # body 2: A = 1.5; (2,3) D = 1 ≤ A → (2,3) = 5, film 0.5
    # body 3: A = 4; (1,3) D = 3.75 ≤ A ((2,3) is full) → (1,3) = 5, film 0.25
    assert s.film == approx(np.array([0.0, 0.0, 0.5, 0.25]) * U)
    assert s.v_b == approx(np.array([0.0, 0.0, 4.25, 5.0, 5.0]) * U)


def test_creation_before_refill_in_same_step():
    s = Scene([0.0, 0.0, 0.0, 0.0], [(0, 1), (1, 2), (1, 3)], v_max=[5.0, 1.0, 5.0])
    s.rupture(0, 4.0)
    s.create(1)
    s.bridge(2, 0.0)
    s.step()
    # step 1: films (2, 2, 0, 0); step 2: (1,2) gets a_1 = 2 → capped to 1, film_1 = 1
    # step 3: body 0 has no live bridge; body 1: A = 1, (1,2) full, (1,3) D = 5 > A → 1, film 0
    assert s.film == approx(np.array([2.0, 0.0, 0.0, 0.0]) * U)
    assert s.v_b == approx(np.array([0.0, 1.0, 1.0]) * U)


def test_dry_rupture_marks_nothing():
    s = Scene([0.0, 3.0, 0.0], [(0, 1), (1, 2)], v_max=5.0)
    s.rupture(0, 0.0)
    s.bridge(1, 0.0)
    s.step()
    assert s.film == approx(np.array([0.0, 3.0, 0.0]) * U)
    assert s.v_b[1] == 0.0


# --------------------------------------------------------------------------- walls


def test_wall_body_participates_like_a_particle():
    # particles 0, 1 and a wall, body 2
    s = Scene([4.0, 0.0, 0.0], [(0, 2), (1, 2)], v_max=[10.0, 3.0])
    s.create(0)
    s.bridge(1, 0.0)
    s.step()
    assert s.v_b == approx(np.array([4.0, 0.0]) * U)
    assert s.film == approx(np.array([0.0, 0.0, 0.0]))
    # the wall bridge ruptures: the wall gets 2, is marked and refills (1,2): D = 3 > 2
    s.rupture(0, 4.0)
    s.step()
    assert s.film == approx(np.array([2.0, 0.0, 0.0]) * U)
    assert s.v_b == approx(np.array([0.0, 2.0]) * U)
    # (1,2) ruptures (wall film 1), particle 0 touches the wall again: the wall offers its film
    s.rupture(1, 2.0)
    s.create(0)
    s.step()
    assert s.v_b == approx(np.array([3.0, 0.0]) * U)
    assert s.film == approx(np.array([0.0, 1.0, 0.0]) * U)


# --------------------------------------------------------------------------- V_min


def test_v_min_in_creation():
    s = Scene([3.0, 1.0, 0.2, 0.5], [(0, 1), (2, 3)], v_max=100.0)
    s.create(0)
    s.create(1)
    s.step(v_min=0.5 * U)
    # a_0 = 2.5, a_1 = 0.5; bodies 2 (below V_min) and 3 (at V_min) offer nothing
    assert s.v_b == approx(np.array([3.0, 0.0]) * U)
    assert s.film == approx(np.array([0.5, 0.5, 0.2, 0.5]) * U)


def test_v_min_in_refill():
    s = Scene([0.5, 0.5, 0.0], [(0, 1), (0, 2), (1, 2)], v_max=5.0)
    s.rupture(0, 2.0)
    s.bridge(1, 0.0)
    s.bridge(2, 4.8)
    s.step(v_min=0.5 * U)
    # films (1.5, 1.5, 0); body 0: A = 1, D = 5 > A → (0,2) = 1, film V_min
    # body 1: A = 1, D = 0.2 ≤ A → (1,2) = 5, film 1.3
    assert s.film == approx(np.array([0.5, 1.3, 0.0]) * U)
    assert s.v_b == approx(np.array([0.0, 1.0, 5.0]) * U)


# --------------------------------------------------------------------------- random sequence


def reference_step(film, pair_i, pair_j, v_b, v_max, alive, created, ruptured, lists, v_min):
    """The rules of "Liquid migration" written out plainly (Python lists and dicts)."""
    marked = set()
    for k in range(len(pair_i)):
        if ruptured[k] > 0:
            for b in (pair_i[k], pair_j[k]):
                film[b] += ruptured[k] / 2
                marked.add(b)
    n_new = {}
    for k in np.flatnonzero(created):
        for b in (pair_i[k], pair_j[k]):
            n_new[b] = n_new.get(b, 0) + 1
    offer = {b: (film[b] - v_min) / n if film[b] > v_min else 0.0 for b, n in n_new.items()}
    take = []
    for k in np.flatnonzero(created):
        a_i, a_j = offer[pair_i[k]], offer[pair_j[k]]
        if a_i + a_j > v_max[k]:
            f = v_max[k] / (a_i + a_j)
            a_i, a_j = a_i * f, a_j * f
        v_b[k] = a_i + a_j
        take += [(pair_i[k], a_i), (pair_j[k], a_j)]
    for b, a in take:
        film[b] = max(film[b] - a, v_min) if a > 0 else film[b]
    for b in sorted(marked):
        avail = film[b] - v_min
        if avail <= 0:
            continue
        open_ = [k for k in lists[b] if alive[k] and v_b[k] < v_max[k]]
        deficit = sum(v_max[k] - v_b[k] for k in open_)
        if not open_:
            continue
        if deficit > avail:
            for k in open_:
                v_b[k] += (v_max[k] - v_b[k]) * avail / deficit
            film[b] = v_min
        else:
            for k in open_:
                v_b[k] = v_max[k]
            film[b] -= deficit


def random_run(seed, v_min, n_steps=400, n_part=12, n_walls=2, p_rup=0.15, p_new=0.10, check_reference=True):
    rng = np.random.default_rng(seed)
    n_bodies = n_part + n_walls
    radius = rng.uniform(0.6e-3, 0.9e-3, n_part)
    pairs = [(i, n_part + w) for i in range(n_part) for w in range(n_walls)]
    pairs += [(i, j) for i in range(n_part) for j in range(i + 1, n_part)]
    pair_i = np.array([p[0] for p in pairs], dtype=np.int64)
    pair_j = np.array([p[1] for p in pairs], dtype=np.int64)
    r_j = np.where(pair_j >= n_part, np.inf, radius[np.minimum(pair_j, n_part - 1)])  # wall: R_i
    r_min = np.minimum(radius[pair_i], r_j)
    v_max = 0.03 * r_min**3
    c = len(pairs)
    start, slots, lists = build_csr(n_bodies, pair_i, pair_j, rng=rng)
    film = np.zeros(n_bodies)
    film[:n_part] = rng.uniform(0.0, 2.0, n_part) * 0.03 * radius**3
    v_b = np.zeros(c)
    alive = np.zeros(c, dtype=bool)
    created = np.zeros(c, dtype=bool)
    ruptured = np.zeros(c)
    expected = total_liquid(film, v_b, alive)
    n_events = 0
    for step in range(n_steps):
        created[:] = False
        ruptured[:] = 0.0
        u = rng.random(c)
        rup = alive & (u < p_rup)
        new = ~alive & (u < p_new)
        ruptured[rup] = v_b[rup]
        v_b[rup] = 0.0
        alive[rup] = False
        alive[new] = True
        created[new] = True
        v_b[new] = 0.0
        n_events += rup.sum() + new.sum()
        if step % 25 == 0:  # spray-like additions to the particle films
            add = rng.uniform(0.0, 0.02, n_part) * (4 / 3) * math.pi * radius**3
            film[:n_part] += add
            expected += add.sum()
        if check_reference:
            ref = (film.copy(), v_b.copy())
            reference_step(ref[0], pair_i, pair_j, ref[1], v_max, alive, created, ruptured, lists, v_min)
        migrate_liquid(film, pair_i, pair_j, v_b, v_max, alive, created, ruptured, start, slots, v_min, np.arange(film.size))
        if check_reference:
            assert film == pytest.approx(ref[0], rel=1e-12, abs=1e-12 * expected)
            assert v_b == pytest.approx(ref[1], rel=1e-12, abs=1e-12 * expected)
        total = total_liquid(film, v_b, alive)
        assert abs(total - expected) <= 1e-12 * expected, step
        assert (film >= 0).all() and (v_b >= 0).all()
        assert (v_b[~alive] == 0).all()
        assert (v_b <= v_max * (1 + 1e-12)).all()
    assert n_events > 100 and (v_b > 0).sum() > 5
    return film, v_b


@pytest.mark.parametrize("v_min", [0.0, 2e-14])
def test_random_sequence_conserves_liquid(v_min):
    random_run(seed=7, v_min=v_min)


def test_random_sequence_many_slots_sparse_events():
    # 40 particles + 2 walls: 860 slots, several blocks of the event scan, most of them quiet
    random_run(seed=11, v_min=0.0, n_steps=250, n_part=40, p_rup=0.03, p_new=0.003)


def test_random_sequence_is_deterministic():
    a = random_run(seed=3, v_min=0.0, n_steps=150, check_reference=False)
    b = random_run(seed=3, v_min=0.0, n_steps=150, check_reference=False)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


# --------------------------------------------------------------------------- spray and totals


def test_spray_doses_inside_zone_only():
    r_s = 0.063
    position = np.array([
        [0.03, 0.04, 0.01],   # r = 0.05, inside
        [0.063, 0.0, 0.0],    # r = r_s exactly: not inside (strict <)
        [0.05, 0.05, 0.02],   # r ≈ 0.0707, outside
        [0.0, 0.0, 0.5],      # on the axis, inside whatever z
        [-0.04, -0.04, 0.0],  # r ≈ 0.0566, inside, but beyond n_particles below
    ])
    radius = np.array([0.75e-3, 0.6e-3, 0.9e-3, 0.8e-3, 0.7e-3])
    film = np.array([1.0, 2.0, 0.0, 0.5, 0.0, 3.0, 0.0]) * U  # two wall bodies at the end
    before = film.copy()
    added = spray(film, position, radius, 4, r_s, 0.01)
    dose = 0.01 * 4.0 / 3.0 * math.pi * radius**3
    expected = before.copy()
    expected[0] += dose[0]
    expected[3] += dose[3]
    assert film == pytest.approx(expected, rel=1e-14, abs=0)
    assert film[[1, 2, 4, 5, 6]].tolist() == before[[1, 2, 4, 5, 6]].tolist()
    assert added == pytest.approx(dose[0] + dose[3], rel=1e-14)
    assert added == pytest.approx((film - before).sum(), rel=1e-12)
    # all five particles now: particle 4 is dosed too
    added = spray(film, position, radius, 5, r_s, 0.01)
    assert added == pytest.approx(dose[0] + dose[3] + dose[4], rel=1e-14)
    assert film[4] == pytest.approx(dose[4], rel=1e-14)


def test_total_liquid_counts_alive_bridges_only():
    film = np.array([1.0, 2.0, 3.0])
    v_b = np.array([10.0, 20.0])
    assert total_liquid(film, v_b, np.array([True, False])) == 16.0
    assert total_liquid(film, v_b, np.array([False, False])) == 6.0
