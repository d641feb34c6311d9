"""The same drum in YADE and in our simulator, from the same settled bed (the YADE side of the
granule-statistics comparison; never needed by the tests).

Three steps, from the repository root:

1. Our run, with the fixed-bridge-volume model (YADE's ViscElCapMat without LiqControl) and no
   viscous force, e.g. the lab drum at CG2::

       python -m sim run --preset lab-cg2 --bridge-volume 1e-12 --no-viscous --gamma 0.1095 --seed 0 \\
           --revolutions 6 --threads 1 --quiet --out build/yade/sim-g0.1095-s0.h5

   (``--bridge-volume`` is the original system's V_b, scaled by α³: 8e-12 m³ at CG2; YADE's
   ViscElCapMat has no lubrication force, hence ``--no-viscous``)

2. ``python benchmarks/yade_same_drum.py prepare build/yade/sim-g0.1095-s0.h5 build/yade/g0.1095-s0``
   writes the run's settled bed (frame 0: positions [m], radii [m]) as ``bed.csv`` and the
   physics as ``setup.json`` (pair stiffness and damping converted to YADE's per-material values:
   a pair of one material gets k = k_m/2, c = c_m/2).

3. ``cd build/yade/g0.1095-s0 && yade -n -j 1 -x ../../../benchmarks/yade_same_drum.py`` runs YADE
   2023.02a (Debian ``yade``) on that bed: ``ViscElCapMat`` with ``Willett_numeric``, the same V_b,
   θ, γ, k, c, μ, a facet drum of the same radius and length with its end plates and four radial
   baffles of 0.15 R_d, all turning at Ω about z, Δt as ours, a frame every 0.05 revolution through
   ``docs/yade_export.py``; then ``granalytics convert out/frame_particles_*.csv --from yade
   --contacts out/frame_contacts_*.csv --mapping meta.toml --dt-s DT --out yade.h5`` (the command
   is printed at the end, with ``meta.toml`` written beside it).

The interaction range: YADE keeps a bridge only while the two spheres' bounding boxes overlap,
so ``aabbEnlargeFactor`` and ``interactionDetectionFactor`` are set to 1 + 1.2·s_crit(V_b)/R_min,
the largest rupture distance over the smallest radius with a margin.
"""

from __future__ import annotations

import json
import math
import os
import sys

_FIELDS = ("x", "y", "z", "r")


def prepare(run_path, folder):
    """Write the settled bed and the physics of our run ``run_path`` to ``folder``."""
    import numpy as np

    import granalytics as ga

    os.makedirs(folder, exist_ok=True)
    with ga.open_run(run_path) as run:
        frame = run[0]
        params = run.meta.sim_config["params"]
        if run.meta.sim_config.get("liquid_model") != "fixed_bridge_volume":
            raise SystemExit(f"{run_path}: not a fixed-bridge-volume run (python -m sim run --bridge-volume ...)")
        setup = {
            "source": os.path.abspath(run_path), "n_particles": int(frame.n_particles),
            "density": params["density"], "kn_material": 2 * params["k_n"], "ks_material": 2 * params["k_t"],
            "cn_material": 2 * params["c_n"], "cs_material": 2 * params["c_t"], "friction": params["friction"],
            "gamma": params["surface_tension"], "theta": params["contact_angle"], "vb": params["bridge_volume"],
            "viscous": params["viscous"], "drum_radius": params["drum_radius"], "drum_length": params["drum_length"],
            "n_baffles": params["n_baffles"], "baffle_height": params["baffle_height"], "omega": params["drum_omega"],
            "gravity": params["gravity"], "dt": params["dt"], "revolutions": float(run.revolutions[-1]),
            "frame_every_rev": float(np.round(np.diff(run.revolutions).mean(), 6)) if len(run) > 1 else 0.05,
            "r_min": float(frame.radius.min()),
            # YADE runs this file as its own script (no __file__ of ours there): the exporter's path
            "exporter": os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "yade_export.py"),
        }
        table = np.column_stack([frame.position, frame.radius])
    np.savetxt(os.path.join(folder, "bed.csv"), table, delimiter=",", header=",".join(_FIELDS), comments="",
               fmt="%.17g")
    with open(os.path.join(folder, "setup.json"), "w") as f:
        json.dump(setup, f, indent=1)
    with open(os.path.join(folder, "meta.toml"), "w") as f:
        f.write(f"surface_tension = {setup['gamma']!r}\ndensity = {setup['density']!r}\n"
                f"drum_omega = {setup['omega']!r}\ncontact_angle = {setup['theta']!r}\n")
    print(f"wrote {folder}/bed.csv ({setup['n_particles']} spheres), setup.json, meta.toml; "
          f"next: cd {folder} && yade -n -j 1 -x {os.path.abspath(__file__)}")


def run_yade():  # pragma: no cover - runs inside YADE
    from yade import geom  # noqa: F401  (YADE's own modules; the names below are YADE's globals)

    setup = json.load(open("setup.json"))
    exec(open(setup["exporter"]).read(), globals())  # docs/yade_export.py: granalytics_export()
    vb, theta, r_min = setup["vb"], setup["theta"], setup["r_min"]
    s_crit = (1 + theta / 2) * (vb ** (1 / 3) + 0.1 * vb ** (2 / 3) / r_min)
    factor = 1 + 1.2 * s_crit / r_min
    mat = O.materials.append(ViscElCapMat(  # noqa: F821
        density=setup["density"], kn=setup["kn_material"], cn=setup["cn_material"], ks=setup["ks_material"],
        cs=setup["cs_material"], frictionAngle=math.atan(setup["friction"]), Capillar=True,
        CapillarType="Willett_numeric", gamma=setup["gamma"], theta=theta, Vb=vb))
    rd, length = setup["drum_radius"], setup["drum_length"]
    walls = geom.facetCylinder((0, 0, length / 2), rd, length, segmentsNumber=96, wallMask=7, material=mat)
    h = setup["baffle_height"] * rd
    for b in range(setup["n_baffles"]):
        a = 2 * math.pi * b / setup["n_baffles"]
        c, s = math.cos(a), math.sin(a)
        p1, p2 = (rd * c, rd * s, 0), ((rd - h) * c, (rd - h) * s, 0)
        p3, p4 = ((rd - h) * c, (rd - h) * s, length), (rd * c, rd * s, length)
        walls += [facet([p1, p2, p3], material=mat), facet([p1, p3, p4], material=mat)]  # noqa: F821
    ids = O.bodies.append(walls)  # noqa: F821
    with open("bed.csv") as f:
        next(f)
        for line in f:
            x, y, z, r = map(float, line.split(","))
            O.bodies.append(sphere((x, y, z), r, material=mat))  # noqa: F821
    os.makedirs("out", exist_ok=True)
    period = 2 * math.pi / abs(setup["omega"])
    every = int(round(setup["frame_every_rev"] * period / setup["dt"]))
    steps = int(round(setup["revolutions"] * period / setup["dt"]))
    O.engines = [  # noqa: F821
        ForceResetter(),  # noqa: F821
        InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=factor), Bo1_Facet_Aabb()], verletDist=0.2 * r_min),  # noqa: F821
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=factor), Ig2_Facet_Sphere_ScGeom()],  # noqa: F821
                        [Ip2_ViscElCapMat_ViscElCapMat_ViscElCapPhys()], [Law2_ScGeom_ViscElCapPhys_Basic()]),  # noqa: F821
        NewtonIntegrator(gravity=tuple(setup["gravity"]), damping=0.0),  # noqa: F821
        RotationEngine(ids=ids, rotationAxis=(0, 0, 1), angularVelocity=setup["omega"], rotateAroundZero=True,  # noqa: F821
                       zeroPoint=(0, 0, 0)),
        PyRunner(iterPeriod=every, initRun=True, command="granalytics_export('out/frame')"),  # noqa: F821
    ]
    O.dt = setup["dt"]  # noqa: F821
    import time

    t0 = time.time()
    O.run(steps + 1, True)  # noqa: F821
    wall = time.time() - t0
    with open("yade_cost.json", "w") as f:
        json.dump({"wall_s": wall, "steps": steps, "threads": O.numThreads, "particles": setup["n_particles"]}, f)  # noqa: F821
    print(f"YADE: {steps} steps of {setup['n_particles']} spheres in {wall:.0f} s; convert with:\n"
          f"granalytics convert out/frame_particles_*.csv --from yade --contacts out/frame_contacts_*.csv "
          f"--mapping meta.toml --dt-s {setup['dt']!r} --out yade.h5")


if __name__ == "__main__" and "O" not in globals():
    if len(sys.argv) != 4 or sys.argv[1] != "prepare":
        raise SystemExit(__doc__)
    prepare(sys.argv[2], sys.argv[3])
elif "O" in globals():  # pragma: no cover - inside YADE
    run_yade()
