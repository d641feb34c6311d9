"""The fast YADE set-up of ``benchmarks/yade_same_drum.py`` against the recipe's earlier one, on one
prepared case (a YADE script; never needed by the tests).

Usage, in a folder written by ``python benchmarks/yade_same_drum.py prepare RUN FOLDER``::

    PLATES=fan IDF=factor STEPS=2000 yade -n -j 1 -x ../../benchmarks/yade_recipe_check.py
    PLATES=tri IDF=factor STEPS=2000 yade -n -j 1 -x ../../benchmarks/yade_recipe_check.py
    PLATES=tri IDF=1      STEPS=2000 yade -n -j 1 -x ../../benchmarks/yade_recipe_check.py

``PLATES``: ``fan`` (the earlier end plates, 2 × 96 triangles meeting on the axis) or ``tri`` (one
triangle per plate, the recipe's now); ``IDF``: ``factor`` (interactionDetectionFactor = the bounds'
enlargement, the earlier set-up) or ``1`` (the recipe's now: only the bounds are enlarged);
``AABB=1`` also drops the bounds' enlargement (which changes the trajectory: bridges then break at
the bounds' edge). Each run prints and writes ``result-PLATES-IDF-STEPS.json``: CPU time, steps per
CPU second, a sha256 of every sphere's position and velocity after ``STEPS`` steps (equal for
``IDF=factor`` and ``IDF=1`` with the same plates: the trajectory is bitwise the same), the
interactions YADE holds against the real ones, and the spheres touching two coplanar facets at once
(a wall force counted twice: with ``fan`` plates on the end plates and, with either, where a
cylinder or baffle rectangle is split into two triangles).
"""
import hashlib
import json
import math
import os
import time

from yade import geom
plates, idf_mode, nsteps = os.environ["PLATES"], os.environ["IDF"], int(os.environ["STEPS"])
setup = json.load(open("setup.json"))
vb, theta, r_min = setup["vb"], setup["theta"], setup["r_min"]
s_crit = (1 + theta / 2) * (vb ** (1 / 3) + 0.1 * vb ** (2 / 3) / r_min)
factor = 1 + 1.2 * s_crit / r_min
mat = O.materials.append(ViscElCapMat(
    density=setup["density"], kn=setup["kn_material"], cn=setup["cn_material"], ks=setup["ks_material"],
    cs=setup["cs_material"], frictionAngle=math.atan(setup["friction"]), Capillar=True,
    CapillarType="Willett_numeric", gamma=setup["gamma"], theta=theta, Vb=vb))
rd, length = setup["drum_radius"], setup["drum_length"]
if plates == "fan":
    walls = geom.facetCylinder((0, 0, length / 2), rd, length, segmentsNumber=96, wallMask=7, material=mat)
else:
    walls = geom.facetCylinder((0, 0, length / 2), rd, length, segmentsNumber=96, wallMask=4, material=mat)
    rc = 2 * rd * 1.0  # circumradius of an equilateral triangle of inradius rd
    for z in (0.0, length):
        walls.append(facet([(rc * math.cos(a), rc * math.sin(a), z) for a in (math.pi / 2 + k * 2 * math.pi / 3 for k in range(3))], material=mat))
h = setup["baffle_height"] * rd
for b in range(setup["n_baffles"]):
    a = 2 * math.pi * b / setup["n_baffles"]
    c, s = math.cos(a), math.sin(a)
    p1, p2 = (rd * c, rd * s, 0), ((rd - h) * c, (rd - h) * s, 0)
    p3, p4 = ((rd - h) * c, (rd - h) * s, length), (rd * c, rd * s, length)
    walls += [facet([p1, p2, p3], material=mat), facet([p1, p3, p4], material=mat)]
ids = O.bodies.append(walls)
with open("bed.csv") as f:
    next(f)
    for line in f:
        x, y, z, r = map(float, line.split(","))
        O.bodies.append(sphere((x, y, z), r, material=mat))
idf = factor if idf_mode == "factor" else 1.0
print("facets", len(ids))
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=(1.0 if os.environ.get("AABB") == "1" else factor)), Bo1_Facet_Aabb()], verletDist=0.2 * r_min),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=idf), Ig2_Facet_Sphere_ScGeom()],
                    [Ip2_ViscElCapMat_ViscElCapMat_ViscElCapPhys()], [Law2_ScGeom_ViscElCapPhys_Basic()]),
    NewtonIntegrator(gravity=tuple(setup["gravity"]), damping=0.0),
    RotationEngine(ids=ids, rotationAxis=(0, 0, 1), angularVelocity=setup["omega"], rotateAroundZero=True, zeroPoint=(0, 0, 0)),
]
O.dt = setup["dt"]

def plane(b):
    v = [b.state.pos + b.state.ori * p for p in b.shape.vertices]
    n = (v[1] - v[0]).cross(v[2] - v[0])
    n = n / n.norm()
    return n, n.dot(v[0])

def doubles():
    wall = set(ids)
    per = {}
    nreal = ntouch = 0
    for i in O.interactions:
        if not i.isReal:
            continue
        if i.id1 in wall or i.id2 in wall:
            f, s = (i.id1, i.id2) if i.id1 in wall else (i.id2, i.id1)
            nreal += 1
            if i.geom.penetrationDepth > 0:
                ntouch += 1
                per.setdefault(s, []).append(f)
    spheres = pairs = 0
    kinds = {}
    for s, fs in per.items():
        planes = [plane(O.bodies[f]) for f in fs]
        found = False
        for a in range(len(fs)):
            for b in range(a + 1, len(fs)):
                (n1, d1), (n2, d2) = planes[a], planes[b]
                if abs(n1.dot(n2)) > 1 - 1e-9 and abs(d1 - (d2 if n1.dot(n2) > 0 else -d2)) < 1e-9:
                    pairs += 1
                    found = True
                    k = "end" if abs(n1[2]) > 0.5 else ("baffle" if abs(d1) < 1e-6 else "cyl")
                    kinds[k] = kinds.get(k, 0) + 1
        spheres += found
    return {"wall_interactions": nreal, "wall_contacts": ntouch, "spheres_touching_wall": len(per),
            "spheres_with_coplanar_double": spheres, "coplanar_pairs": pairs, "by_wall": kinds}

t0, c0 = time.time(), time.process_time()
O.run(nsteps, True)
wall_s, cpu_s = time.time() - t0, time.process_time() - c0
pos = "\n".join(repr((b.id, tuple(b.state.pos), tuple(b.state.vel))) for b in O.bodies if isinstance(b.shape, Sphere))
res = {"plates": plates, "idf": idf, "steps": nsteps, "wall_s": wall_s, "cpu_s": cpu_s,
       "steps_per_cpu_s": nsteps / cpu_s, "hash": hashlib.sha256(pos.encode()).hexdigest()[:16],
       "n_interactions": len(O.interactions), "n_real": sum(1 for i in O.interactions if i.isReal), **doubles()}
print("RESULT", json.dumps(res))
open("result-%s-%s-%d.json" % (plates, idf_mode, nsteps), "w").write(json.dumps(res))
open("pos-%s-%s-%d%s.txt" % (plates, idf_mode, nsteps, os.environ.get("AABB", "")), "w").write(pos)
