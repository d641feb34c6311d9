# The YADE side of the throughput comparison (run by benchmarks/sim_throughput.py with yade -x); the reference
# case with its planar lattice replaced by a 3-D one (see below).
# YADE anchor: wet rotating baffled drum (ViscElCapMat, Willett_numeric), throughput in particle-steps/s.
# Spheres start on a 3-D lattice in the lower part of the drum, settle with numerical damping, then the
# measured window runs with the study's parameters (dt 3e-6 s, no numerical damping, 2 rad/s).
# Run: yade -n -j THREADS -x yade_drum_throughput.py RD L SETTLE_STEPS MEASURE_STEPS
import sys, time, math, random
from yade import geom
RD, L, SETTLE, MEASURE = float(sys.argv[-4]), float(sys.argv[-3]), int(sys.argv[-2]), int(sys.argv[-1])
mat = O.materials.append(ViscElCapMat(density=2500, kn=300.0, cn=0.0022, ks=240.0, cs=0.0022,
                                      frictionAngle=math.atan(0.5), Capillar=True,
                                      CapillarType="Willett_numeric", gamma=0.1095, theta=0.0, Vb=1e-11))
drum = geom.facetCylinder((0, 0, L / 2), RD, L, segmentsNumber=64, wallMask=7, material=mat)
baffles = []
h = 0.15 * RD
for k in range(4):
    a = k * math.pi / 2
    c, s = math.cos(a), math.sin(a)
    p1 = (RD * c, RD * s, 0); p2 = ((RD - h) * c, (RD - h) * s, 0)
    p3 = ((RD - h) * c, (RD - h) * s, L); p4 = (RD * c, RD * s, L)
    baffles += [facet([p1, p2, p3], material=mat), facet([p1, p3, p4], material=mat)]
fids = O.bodies.append(drum + baffles)
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
for (x, y, z, r) in atoms:
    O.bodies.append(sphere((x, y, z), r, material=mat))
n = len(atoms)
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], verletDist=0.2e-3),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                             [Ip2_ViscElCapMat_ViscElCapMat_ViscElCapPhys()],
                             [Law2_ScGeom_ViscElCapPhys_Basic()]),
             NewtonIntegrator(gravity=(0, -9.81, 0), damping=0.5, label="newton"),
             RotationEngine(ids=fids, rotationAxis=(0, 0, 1), angularVelocity=2.0, rotateAroundZero=True, zeroPoint=(0, 0, 0))]
O.dt = 3e-6
t0 = time.time(); O.run(SETTLE, True); ts = time.time() - t0
newton.damping = 0.0
O.run(500, True)
t0 = time.time(); O.run(MEASURE, True); t = time.time() - t0
nint = sum(1 for i in O.interactions if i.isReal)
br = sum(1 for i in O.interactions if i.isReal and i.phys.liqBridgeActive)
print(f"RESULT particles={n} threads={O.numThreads} measure_steps={MEASURE} wall_s={t:.2f} "
      f"particle_steps_per_s={n*MEASURE/t:.3e} interactions_per_particle={2*nint/n:.2f} active_bridges={br} settle_wall_s={ts:.1f}")
