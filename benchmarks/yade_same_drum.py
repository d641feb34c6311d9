"""The same drum in YADE and in our simulator, from the same settled bed (the YADE side of the
granule-statistics comparison; never needed by the tests).

``benchmarks/yade_series.py`` runs the whole chain below for several γ and seeds. By hand, from the
repository root:

1. Our run, with the fixed-bridge-volume model (YADE's ViscElCapMat without LiqControl) and no
   viscous force, e.g. the lab drum at CG2::

       python -m sim run --preset lab-cg2 --bridge-volume 1e-12 --no-viscous --gamma 0.1095 --seed 0 \\
           --revolutions 3 --threads 1 --quiet --out build/yade/sim-g0.1095-s0.h5

   (``--bridge-volume`` is the original system's V_b, scaled by α³: 8e-12 m³ at CG2; YADE's
   ViscElCapMat has no lubrication force, hence ``--no-viscous``)

2. ``python benchmarks/yade_same_drum.py prepare build/yade/sim-g0.1095-s0.h5 build/yade/g0.1095-s0``
   writes the run's settled bed (frame 0: positions [m], radii [m]) as ``bed.csv``, the physics
   and the frame steps as ``setup.json`` (pair stiffness and damping converted to YADE's
   per-material values: a pair of one material gets k = k_m/2, c = c_m/2) and the mapping of
   ``granalytics convert`` as ``meta.toml`` (γ [N/m], ρ [kg/m³], Ω [rad/s], θ [rad] and α of our
   run: the converted run is a CG run of the same factor).
   The wall experiments' switches: ``--cylinder-segments N`` (96 by default) and
   ``--no-wall-bridges`` (the walls' material gets ``Capillar=False``: no bridge with a wall).

3. ``cd build/yade/g0.1095-s0 && yade -n -j 1 -x ../../../benchmarks/yade_same_drum.py`` runs YADE
   2023.02a (Debian ``yade``) on that bed: ``ViscElCapMat`` with ``Willett_numeric``, the same V_b,
   θ, γ, k, c, μ and gravity, a facet drum of the same radius and length with its end plates and
   four radial baffles of 0.15 R_d, all turning at Ω about z, Δt as ours, a frame (``out/``, through
   ``scripts/yade_export.py``) at every step at which our run wrote one, the last at our run's last
   revolution. It ends by printing its cost and writing it to ``cost.json`` (wall and CPU time of
   the stepping [s], steps, steps per second of each, and the wall contacts counted below).

4. ``python benchmarks/yade_same_drum.py convert build/yade/g0.1095-s0 build/yade/yade-g0.1095-s0.h5``
   converts ``out/`` as ``granalytics convert out/frame_particles_*.csv --from yade --contacts
   out/frame_contacts_*.csv --mapping meta.toml`` does, and sets the run's gravity to the drum's
   (−y, from ``setup.json``: the YADE mapping has no gravity key, so ``granalytics convert`` records
   its default −z) and adds ``cost.json`` and our run's path to its provenance.

The walls: the cylinder is ``geom.facetCylinder``'s side (96 flat segments, each a rectangle split
into two triangles along a diagonal), each end plate ONE equilateral triangle in the plate's plane,
centred on the axis, whose inscribed circle has radius R_d (it covers the drum's disc at every
angle). ``facetCylinder``'s own end plates are fans of 96 triangles meeting on the axis: their
bounding boxes all reach the axis, so that a sphere near a plate is a candidate of many of them
(about 15 000 potential interactions in the lab-cg2 drum against 4 000 with one triangle per plate,
1.6× the CPU time per step), and a sphere on the edge shared by two coplanar triangles gets the
wall's force from each of them. The cylinder's and the baffles' split rectangles keep that double
force where a sphere lies on a diagonal: the run counts, at its last step, the spheres that touch
two coplanar facets (``cost.json``: ``coplanar_doubles`` beside ``wall_contacts``; 17 of 180–210
wall contacts in the lab-cg2 drum over its first 0.2 revolution, nearly all on the cylinder).

The interaction range: YADE keeps a bridge only while the two spheres' bounding boxes overlap, so
``aabbEnlargeFactor`` is 1 + 1.2·s_crit(V_b)/R_min (the largest rupture distance over the smallest
radius, with a margin). ``interactionDetectionFactor`` stays 1: a bridge forms at contact, and a
larger factor only makes YADE build and erase a geometry and a physics object for every near pair
at every step (the same trajectory to the last bit over 30 000 steps, 1.5× the CPU time per step).
"""

from __future__ import annotations

import json
import math
import os
import sys

_FIELDS = ("x", "y", "z", "r")


def prepare(run_path, folder, cylinder_segments=96, wall_bridges=True):
    """Write the settled bed, the physics and the mapping of our run ``run_path`` to ``folder``.

    Parameters
    ----------
    run_path : str
        Our fixed-bridge-volume run (``python -m sim run --bridge-volume ...``).
    folder : str
        Folder to write ``bed.csv``, ``setup.json`` and ``meta.toml`` to (made if missing).
    cylinder_segments : int
        Flat segments of the facet cylinder (96: the recipe's; more make the wall smoother).
    wall_bridges : bool
        Whether spheres form capillary bridges with the walls (True, as in our simulator; False:
        the walls' material has ``Capillar=False``, the switch of the wall experiments).
    """
    import numpy as np

    import granalytics as ga

    os.makedirs(folder, exist_ok=True)
    with ga.open_run(run_path) as run:
        frame = run[0]
        params = run.meta.sim_config["params"]
        if run.meta.sim_config.get("liquid_model") != "fixed_bridge_volume":
            raise SystemExit(f"{run_path}: not a fixed-bridge-volume run (python -m sim run --bridge-volume ...)")
        steps = np.array([s.step for s in run], dtype=np.int64) - frame.step  # frame k's step after the bed
        every = int(steps[1]) if len(steps) > 1 else 0
        if every <= 0 or not np.array_equal(steps, every * np.arange(len(steps))):
            raise SystemExit(f"{run_path}: frames are not evenly spaced in steps ({steps[:4].tolist()} ...)")
        setup = {
            "source": os.path.abspath(run_path), "n_particles": int(frame.n_particles),
            "density": params["density"], "kn_material": 2 * params["k_n"], "ks_material": 2 * params["k_t"],
            "cn_material": 2 * params["c_n"], "cs_material": 2 * params["c_t"], "friction": params["friction"],
            "gamma": params["surface_tension"], "theta": params["contact_angle"], "vb": params["bridge_volume"],
            "viscous": params["viscous"], "drum_radius": params["drum_radius"], "drum_length": params["drum_length"],
            "n_baffles": params["n_baffles"], "baffle_height": params["baffle_height"], "omega": params["drum_omega"],
            "gravity": params["gravity"], "dt": params["dt"], "alpha": float(run.meta.alpha),
            "revolutions": float(run.revolutions[-1]), "frame_every_steps": every, "n_frames": len(steps) - 1,
            "r_min": float(frame.radius.min()), "cylinder_segments": int(cylinder_segments),
            "wall_bridges": bool(wall_bridges),
            # YADE runs this file as its own script (no __file__ of ours there): the exporter's path
            "exporter": os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts",
                                                      "yade_export.py")),
            "recipe": os.path.abspath(__file__),
        }
        table = np.column_stack([frame.position, frame.radius])
    np.savetxt(os.path.join(folder, "bed.csv"), table, delimiter=",", header=",".join(_FIELDS), comments="",
               fmt="%.17g")
    with open(os.path.join(folder, "setup.json"), "w") as f:
        json.dump(setup, f, indent=1)
    with open(os.path.join(folder, "meta.toml"), "w") as f:
        f.write(f"surface_tension = {setup['gamma']!r}\ndensity = {setup['density']!r}\n"
                f"drum_omega = {setup['omega']!r}\ncontact_angle = {setup['theta']!r}\nalpha = {setup['alpha']!r}\n")
    print(f"wrote {folder}/bed.csv ({setup['n_particles']} spheres), setup.json, meta.toml; "
          f"next: cd {folder} && yade -n -j 1 -x {os.path.abspath(__file__)}")


def convert(folder, out, overwrite=False):
    """Convert the YADE run in ``folder`` (``out/``, ``meta.toml``, ``setup.json``, ``cost.json``)
    into the run file ``out``, with the drum's gravity [m/s²] and the run's cost in its metadata."""
    import glob

    from granalytics.convert.registry import read_run_files
    from granalytics.core import RunWriter, replacing_run

    particles = sorted(glob.glob(os.path.join(folder, "out", "frame_particles_*.csv")))
    contacts = sorted(glob.glob(os.path.join(folder, "out", "frame_contacts_*.csv")))
    with open(os.path.join(folder, "setup.json")) as f:
        setup = json.load(f)
    with open(os.path.join(folder, "cost.json")) as f:  # written when the YADE run has finished
        cost = json.load(f)
    if len(particles) != setup["n_frames"] + 1:
        raise SystemExit(f"{folder}/out: {len(particles)} particle files, expected {setup['n_frames'] + 1}")
    snapshots, meta = read_run_files("yade", particles, contacts, os.path.join(folder, "meta.toml"))
    meta.gravity = tuple(float(g) for g in setup["gravity"])  # the YADE mapping has no gravity key
    meta.provenance.update({"gravity": "the YADE run's NewtonIntegrator.gravity (setup.json)",
                            "settled_bed_of": setup["source"], "yade_cost": cost})
    with replacing_run(out, overwrite) as tmp, RunWriter(tmp, meta, overwrite=True) as writer:
        for snapshot in snapshots:
            writer.append(snapshot)
    print(f"wrote {out}: {len(snapshots)} frames of {meta.n_particles} particles "
          f"(to {snapshots[-1].time * abs(meta.drum_omega) / (2 * math.pi):.4g} revolutions)")


def coplanar_doubles(wall_ids):  # pragma: no cover - runs inside YADE
    """Wall contacts that YADE counts twice, at the current step.

    Parameters
    ----------
    wall_ids : sequence of int
        Body ids of the facets.

    Returns
    -------
    doubles : int
        Spheres touching (overlap > 0) two facets of one plane (a split rectangle's two
        triangles), each of which applies its force.
    wall_contacts : int
        Sphere–facet contacts with overlap > 0.
    """
    walls, touching = set(wall_ids), {}
    for i in O.interactions:  # noqa: F821
        if i.isReal and (i.id1 in walls) != (i.id2 in walls) and i.geom.penetrationDepth > 0:
            facet_id, sphere_id = (i.id1, i.id2) if i.id1 in walls else (i.id2, i.id1)
            touching.setdefault(sphere_id, []).append(facet_id)

    def plane(body):  # unit normal and offset of the facet's plane, in the global frame
        v = [body.state.pos + body.state.ori * p for p in body.shape.vertices]
        n = (v[1] - v[0]).cross(v[2] - v[0])
        n = n / n.norm()
        return n, n.dot(v[0])

    def same_plane(p, q):
        (n1, d1), (n2, d2) = p, q
        return abs(n1.dot(n2)) > 1 - 1e-9 and abs(d1 - d2 * math.copysign(1.0, n1.dot(n2))) < 1e-9

    doubles = 0
    for facets in touching.values():
        planes = [plane(O.bodies[f]) for f in facets]  # noqa: F821
        doubles += any(same_plane(p, q) for a, p in enumerate(planes) for q in planes[a + 1:])
    return doubles, sum(map(len, touching.values()))


def wall_bridges_per_sphere(surface_of):  # pragma: no cover - runs inside YADE
    """Sphere–surface pairs holding a wall bridge, and those holding two or more bridges with one
    surface (one per facet of it the sphere touched and has not yet left by s_crit; a smooth wall
    has one), at the current step: ``(pairs, pairs_with_two_or_more, bridges)``. ``surface_of``
    maps a facet's body id to its surface (the cylinder, an end plate, a baffle); a bridge counts
    from its touch (``liqBridgeCreated``) to its rupture."""
    count = {}
    for i in O.interactions:  # noqa: F821
        if i.isReal and (i.id1 in surface_of) != (i.id2 in surface_of) and getattr(i.phys, "liqBridgeCreated", False):
            facet_id, sphere_id = (i.id1, i.id2) if i.id1 in surface_of else (i.id2, i.id1)
            key = (sphere_id, surface_of[facet_id])
            count[key] = count.get(key, 0) + 1
    return len(count), sum(1 for c in count.values() if c >= 2), sum(count.values())


def run_yade():  # pragma: no cover - runs inside YADE
    """The YADE run on ``bed.csv`` and ``setup.json`` in the working folder (see the module docstring)."""
    import time

    from yade import geom  # noqa: F401  (YADE's own modules; the names below are YADE's globals)

    t_start = time.time()
    setup = json.load(open("setup.json"))
    exec(open(setup["exporter"]).read(), globals())  # scripts/yade_export.py: granalytics_export()
    vb, theta, r_min = setup["vb"], setup["theta"], setup["r_min"]
    s_crit = (1 + theta / 2) * (vb ** (1 / 3) + 0.1 * vb ** (2 / 3) / r_min)
    factor = 1 + 1.2 * s_crit / r_min
    mat = O.materials.append(ViscElCapMat(  # noqa: F821
        density=setup["density"], kn=setup["kn_material"], cn=setup["cn_material"], ks=setup["ks_material"],
        cs=setup["cs_material"], frictionAngle=math.atan(setup["friction"]), Capillar=True,
        CapillarType="Willett_numeric", gamma=setup["gamma"], theta=theta, Vb=vb))
    sphere_mat = mat
    if not setup.get("wall_bridges", True):  # the walls' own material: no bridges with them
        mat = O.materials.append(ViscElCapMat(  # noqa: F821
            density=setup["density"], kn=setup["kn_material"], cn=setup["cn_material"], ks=setup["ks_material"],
            cs=setup["cs_material"], frictionAngle=math.atan(setup["friction"]), Capillar=False))
    rd, length = setup["drum_radius"], setup["drum_length"]
    # wallMask 4: the side only (1 and 2 are facetCylinder's fans at -z and +z)
    walls = geom.facetCylinder((0, 0, length / 2), rd, length, segmentsNumber=setup.get("cylinder_segments", 96),
                               wallMask=4, material=mat)
    corners = [2 * math.pi * k / 3 + math.pi / 2 for k in range(3)]  # circumradius 2 R_d = inradius R_d
    for z in (0.0, length):
        walls.append(facet([(2 * rd * math.cos(a), 2 * rd * math.sin(a), z) for a in corners],  # noqa: F821
                           material=mat))
    h = setup["baffle_height"] * rd
    for b in range(setup["n_baffles"]):
        a = 2 * math.pi * b / setup["n_baffles"]
        c, s = math.cos(a), math.sin(a)
        p1, p2 = (rd * c, rd * s, 0), ((rd - h) * c, (rd - h) * s, 0)
        p3, p4 = ((rd - h) * c, (rd - h) * s, length), (rd * c, rd * s, length)
        walls += [facet([p1, p2, p3], material=mat), facet([p1, p3, p4], material=mat)]  # noqa: F821
    ids = O.bodies.append(walls)  # noqa: F821
    n_cylinder = len(walls) - 2 - 2 * setup["n_baffles"]  # the cylinder's facets, then 2 plates, then 2 per baffle
    surface_of = {body: ("cylinder" if k < n_cylinder else f"plate {k - n_cylinder}" if k < n_cylinder + 2
                         else f"baffle {(k - n_cylinder - 2) // 2}") for k, body in enumerate(ids)}
    with open("bed.csv") as f:
        next(f)
        for line in f:
            x, y, z, r = map(float, line.split(","))
            O.bodies.append(sphere((x, y, z), r, material=sphere_mat))  # noqa: F821
    os.makedirs("out", exist_ok=True)
    every = setup["frame_every_steps"]
    steps = setup["n_frames"] * every  # our run's frames: the last one at its last revolution
    O.engines = [  # noqa: F821
        ForceResetter(),  # noqa: F821
        InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=factor), Bo1_Facet_Aabb()], verletDist=0.2 * r_min),  # noqa: F821
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=1.0), Ig2_Facet_Sphere_ScGeom()],  # noqa: F821
                        [Ip2_ViscElCapMat_ViscElCapMat_ViscElCapPhys()], [Law2_ScGeom_ViscElCapPhys_Basic()]),  # noqa: F821
        # before the integrator: positions, contacts and forces of one instant, O.time = O.iter·Δt
        PyRunner(iterPeriod=every, initRun=True, command="granalytics_export('out/frame')"),  # noqa: F821
        NewtonIntegrator(gravity=tuple(setup["gravity"]), damping=0.0),  # noqa: F821
        RotationEngine(ids=ids, rotationAxis=(0, 0, 1), angularVelocity=setup["omega"], rotateAroundZero=True,  # noqa: F821
                       zeroPoint=(0, 0, 0)),
    ]
    O.dt = setup["dt"]  # noqa: F821
    t0, c0 = time.time(), time.process_time()
    O.run(steps + 1, True)  # iterations 0 … steps: frames at 0, every, …, steps  # noqa: F821
    wall, cpu = time.time() - t0, time.process_time() - c0
    doubles, wall_contacts = coplanar_doubles(ids)
    try:
        bridged, multiple, wall_bridges = wall_bridges_per_sphere(surface_of)
    except Exception as error:  # a diagnostic: never lose the run's cost for it
        bridged = multiple = wall_bridges = f"not counted: {error}"
    cost = {"wall_s": wall, "cpu_s": cpu, "steps": steps, "steps_per_wall_s": steps / wall,
            "steps_per_cpu_s": steps / cpu, "setup_wall_s": t0 - t_start, "threads": O.numThreads,  # noqa: F821
            "particles": setup["n_particles"], "frames": setup["n_frames"] + 1, "revolutions": setup["revolutions"],
            "coplanar_doubles": doubles, "wall_contacts": wall_contacts, "sphere_wall_pairs_bridged": bridged,
            "sphere_wall_pairs_with_two_or_more_bridges": multiple, "wall_bridges": wall_bridges}
    with open("cost.json", "w") as f:
        json.dump(cost, f, indent=1)
    print(f"YADE cost: {steps} steps of {setup['n_particles']} spheres in {wall:.1f} s wall, {cpu:.1f} s CPU "
          f"({steps / wall:.0f} steps/s wall, {steps / cpu:.0f} steps/s CPU, {O.numThreads} thread(s)); "  # noqa: F821
          f"last step: {doubles} of {wall_contacts} wall contacts doubled by coplanar facets; cost.json; next:\n"
          f"python {setup['recipe']} convert {os.getcwd()} yade.h5")


def _prepare_command(argv):
    import argparse

    parser = argparse.ArgumentParser(prog="yade_same_drum.py prepare", description=prepare.__doc__.splitlines()[0])
    parser.add_argument("run", help="our fixed-bridge-volume run (.h5)")
    parser.add_argument("folder", help="folder of the YADE case")
    parser.add_argument("--cylinder-segments", type=int, default=96, help="flat segments of the cylinder (96)")
    parser.add_argument("--no-wall-bridges", action="store_true", help="no capillary bridges with the walls")
    args = parser.parse_args(argv)
    if args.cylinder_segments < 3:
        parser.error(f"--cylinder-segments: {args.cylinder_segments} is below 3")
    prepare(args.run, args.folder, args.cylinder_segments, not args.no_wall_bridges)


if __name__ == "__main__" and "O" not in globals():
    if len(sys.argv) >= 4 and sys.argv[1] == "prepare":
        _prepare_command(sys.argv[2:])
    elif len(sys.argv) in (4, 5) and sys.argv[1] == "convert" and sys.argv[4:] in ([], ["--overwrite"]):
        convert(sys.argv[2], sys.argv[3], overwrite=len(sys.argv) == 5)
    else:
        raise SystemExit(__doc__)
elif "O" in globals():  # pragma: no cover - inside YADE
    run_yade()
