"""LIGGGHTS throughput anchor: the drum of benchmarks/yade_drum_throughput.py.
Writes drum.stl (closed cylinder R_D x L, 64 segments, 4 radial baffles of 0.15 R_D) and
drum.data (the same lattice positions and radii as the YADE script: random.seed(1), same loop).
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
random.seed(1)
a = 1.85e-3
atoms = []
x = -RD + a
while x < RD - a:
    y = -RD + a
    while y < -0.2 * RD:
        z = a
        while z < L - a:
            if math.hypot(x, y) < RD - 1.2 * a:
                atoms.append((x, y, z, 0.75e-3 * random.uniform(0.8, 1.2)))
            z += a
        y += a
    x += a
m = 0.002
with open("drum.data", "w") as f:
    f.write(f"LIGGGHTS drum lattice\n\n{len(atoms)} atoms\n1 atom types\n\n")
    f.write(f"{-RD-m} {RD+m} xlo xhi\n{-RD-m} {RD+m} ylo yhi\n{-m} {L+m} zlo zhi\n\nAtoms\n\n")
    for i, (x, y, z, r) in enumerate(atoms, 1):
        f.write(f"{i} 1 {2*r:.9g} 2500 {x:.9g} {y:.9g} {z:.9g}\n")
print(len(atoms), "particles")
