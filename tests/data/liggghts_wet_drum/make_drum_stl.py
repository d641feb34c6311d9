"""Write drum.stl for in.wetdrum: a closed cylinder (R = 20 mm, L = 10 mm, 48 segments) with
four radial baffles of height 0.15 R. Run: python make_drum_stl.py && liggghts -in in.wetdrum"""
import math

R, L, n = 0.02, 0.01, 48
tri = []
for k in range(n):
    a0, a1 = 2 * math.pi * k / n, 2 * math.pi * (k + 1) / n

    def p(a, z):
        return (R * math.cos(a), R * math.sin(a), z)

    tri += [(p(a0, 0), p(a1, 0), p(a1, L)), (p(a0, 0), p(a1, L), p(a0, L))]
    tri += [((0, 0, 0), p(a1, 0), p(a0, 0)), ((0, 0, L), p(a0, L), p(a1, L))]
h = 0.15 * R
for b in range(4):
    a = 2 * math.pi * b / 4
    c, s = math.cos(a), math.sin(a)
    q1, q2, q3, q4 = (R * c, R * s, 0), ((R - h) * c, (R - h) * s, 0), ((R - h) * c, (R - h) * s, L), (R * c, R * s, L)
    tri += [(q1, q2, q3), (q1, q3, q4)]
with open("drum.stl", "w") as f:
    f.write("solid drum\n")
    for t in tri:
        f.write(" facet normal 0 0 0\n  outer loop\n")
        for v in t:
            f.write("   vertex %.9g %.9g %.9g\n" % v)
        f.write("  endloop\n endfacet\n")
    f.write("endsolid drum\n")
