# The YADE VTKRecorder fixture of granalytics' yade-vtk reader, made by YADE itself:
#     cd tests/data/yade_vtk && yade -n -x make_fixture.py multiblock   # frames 12000, 16000 (.vtm)
#     cd tests/data/yade_vtk && yade -n -x make_fixture.py single       # frame 12000 (-spheres.vtu, -intrs.vtp)
# The drum, particles and ViscElCapMat bridges are those of ../yade_wet_drum (246 spheres, fixed
# bridge volume 1e-11 m3, Willett_numeric). Beside each VTK frame, the CSV export of
# scripts/yade_export.py writes what O.interactions holds at the same instant (both engines sit
# between InteractionLoop and NewtonIntegrator): the truth the reader's rule is tested against
# (tests/test_yade_vtk.py). In YADE 2023.02a the 'intr' recorder without multiblock=True writes its
# first frame and then crashes (segmentation fault): the 'single' layout therefore has one frame.
import math, os, random, sys
from yade import geom
exec(open("../../../scripts/yade_export.py").read())
layout = sys.argv[1] if len(sys.argv) > 1 else "multiblock"
RD, L = 0.02, 0.008
mat = O.materials.append(ViscElCapMat(density=2500, kn=300.0, cn=0.0022, ks=240.0, cs=0.0022,
                                      frictionAngle=math.atan(0.5), Capillar=True,
                                      CapillarType="Willett_numeric", gamma=0.1095, theta=0.0, Vb=1e-11))
fids = O.bodies.append(geom.facetCylinder((0, 0, L / 2), RD, L, segmentsNumber=48, wallMask=7, material=mat))
random.seed(1)
a = 1.85e-3
y, row = -RD + a, 0
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
os.makedirs(layout, exist_ok=True)
first, period = 12000, (4000 if layout == "multiblock" else 12000)
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], verletDist=0.2e-3),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                             [Ip2_ViscElCapMat_ViscElCapMat_ViscElCapPhys()],
                             [Law2_ScGeom_ViscElCapPhys_Basic()]),
             PyRunner(iterPeriod=4000, initRun=False,
                      command="O.iter >= %d and granalytics_export('%s/truth')" % (first, layout)),
             VTKRecorder(iterPeriod=period, initRun=False, fileName=layout + "/drum-",
                         multiblock=(layout == "multiblock"), recorders=["spheres", "velocity", "id", "intr"]),
             NewtonIntegrator(gravity=(0, -9.81, 0), damping=0.0),
             RotationEngine(ids=fids, rotationAxis=(0, 0, 1), angularVelocity=2.0, rotateAroundZero=True,
                            zeroPoint=(0, 0, 0))]
O.dt = 3e-6
O.run(16001 if layout == "multiblock" else 12001, True)
# the first two multiblock frames (4000, 8000) hold a bed still falling, without contacts: not kept
import shutil
for early in ("4000", "8000"):
    if os.path.exists("multiblock/drum-%s.vtm" % early):
        os.remove("multiblock/drum-%s.vtm" % early)
        shutil.rmtree("multiblock/drum-%s" % early)
