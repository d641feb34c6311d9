"""LIGGGHTS throughput anchor: the drum of benchmarks/yade_drum_throughput.py.
Writes drum.stl (closed cylinder R_D x L, 64 segments, 4 radial baffles of 0.15 R_D) and
drum.data (the same 3-D lattice positions and radii as the YADE script: the same seed and loop).
Run: python3 make_drum.py RD L"""
import math, random, sys
RD, L = float(sys.argv[1]), float(sys.argv[2])
n_seg = 64
tri = []
def p(a, z): return (RD * math.cos(a), RD * math.sin(a), z)
for k in range(n_seg):
    a0, a1 = 2 * math.pi * k / n_seg, 2 * math.pi * (k + 1) / n_seg
    tri += [(p(a0, 0), p(a1, 0), p(a1, L)), (p(a0, 0), p(a1, L), p(a0, L))]
    tri += [((0, 0, 0), p(a1, 0), p(a0, 0)), ((0, 0, L), p(a0, L), p(a1, L))]
h = 0.15 * RD
for b in range(4):
    a = b * math.pi / 2; c, s = math.cos(a), math.sin(a)
    q1, q2, q3, q4 = (RD*c, RD*s, 0), ((RD-h)*c, (RD-h)*s, 0), ((RD-h)*c, (RD-h)*s, L), (RD*c, RD*s, L)
    tri += [(q1, q2, q3), (q1, q3, q4)]
with open("drum.stl", "w") as f:
    f.write("solid drum\n")
    for t in tri:
        f.write(" facet normal 0 0 0\n  outer loop\n")
        for v in t: f.write("   vertex %.9g %.9g %.9g\n" % v)
        f.write("  endloop\n endfacet\n")
    f.write("endsolid drum\n")
# A 3-D lattice (the same sites, radii and offsets as benchmarks/sim_throughput.py::drum_lattice
# and liggghts_drum/make_drum.py): rows of spacing a, every other row (along y, against gravity)
# shifted by a/2 in x and z so that it nests into the row below as the bed settles, and every
# sphere moved by a random offset in x, y and z within the ball of radius a/2 - r around its site.
random.seed(1)
a = 1.85e-3
atoms = []
y = -RD + a
row = 0
while y < -0.2 * RD:
    shift = 0.5 * a * (row % 2)
    x = -RD + a + shift
    while x < RD - a:
        z = a + shift
        while z < L - a:
            if math.hypot(x, y) < RD - 1.2 * a:
                r = 0.75e-3 * random.uniform(0.8, 1.2)
                d = [random.gauss(0, 1) for _ in range(3)]
                s = (0.5 * a - r) * random.random() ** (1 / 3) / math.sqrt(sum(c * c for c in d))
                atoms.append((x + s * d[0], y + s * d[1], z + s * d[2], r))
            z += a
        x += a
    y += a
    row += 1
m = 0.002
with open("drum.data", "w") as f:
    f.write(f"LIGGGHTS drum lattice\n\n{len(atoms)} atoms\n1 atom types\n\n")
    f.write(f"{-RD-m} {RD+m} xlo xhi\n{-RD-m} {RD+m} ylo yhi\n{-m} {L+m} zlo zhi\n\nAtoms\n\n")
    for i, (x, y, z, r) in enumerate(atoms, 1):
        f.write(f"{i} 1 {2*r:.9g} 2500 {x:.9g} {y:.9g} {z:.9g}\n")
print(len(atoms), "particles")
