# Small wet rotating drum in YADE 2023.02a for the granalytics YADE reader fixture.
import math, random
from yade import geom
exec(open("../../../scripts/yade_export.py").read())  # run from tests/data/yade_wet_drum
RD, L = 0.02, 0.008
mat = O.materials.append(ViscElCapMat(density=2500, kn=300.0, cn=0.0022, ks=240.0, cs=0.0022,
                                      frictionAngle=math.atan(0.5), Capillar=True,
                                      CapillarType="Willett_numeric", gamma=0.1095, theta=0.0, Vb=1e-11))
drum = geom.facetCylinder((0, 0, L / 2), RD, L, segmentsNumber=48, wallMask=7, material=mat)
fids = O.bodies.append(drum)
random.seed(1)
a = 1.85e-3
# a 3-D lattice (benchmarks/_bench.py::drum_lattice): every other row nested into the one below, random offsets
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
                O.bodies.append(sphere((x + s * d[0], y + s * d[1], z + s * d[2]), r, material=mat))
            z += a
        x += a
    y += a
    row += 1
import os
os.makedirs("out", exist_ok=True)
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], verletDist=0.2e-3),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                             [Ip2_ViscElCapMat_ViscElCapMat_ViscElCapPhys()],
                             [Law2_ScGeom_ViscElCapPhys_Basic()]),
             NewtonIntegrator(gravity=(0, -9.81, 0), damping=0.0),
             RotationEngine(ids=fids, rotationAxis=(0, 0, 1), angularVelocity=2.0, rotateAroundZero=True, zeroPoint=(0, 0, 0)),
             PyRunner(iterPeriod=4000, initRun=False, command="granalytics_export('out/frame')")]
O.dt = 3e-6
O.run(16001, True)
