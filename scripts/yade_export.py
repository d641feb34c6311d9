# granalytics export for YADE (ViscElCapMat / Law2_ScGeom_ViscElCapPhys_Basic runs).
#
# Use inside a YADE script:
#     exec(open("yade_export.py").read())
#     O.engines += [PyRunner(iterPeriod=5000, command="granalytics_export('out/frame')")]
# Appended after NewtonIntegrator as here, a frame's positions are one step ahead of its contacts and
# of the time it records; placed between InteractionLoop and NewtonIntegrator (as
# benchmarks/yade_same_drum.py does), positions, contacts and forces are of one instant, O.time.
# Each call writes out/frame_particles_<step>.csv and out/frame_contacts_<step>.csv; convert with
#     granalytics convert out/frame_particles_*.csv --from yade --contacts out/frame_contacts_*.csv \
#         --mapping map.toml --dt-s <O.dt> --out run.h5
# Particles: every Sphere (id, radius [m], position [m], velocity [m/s], angular velocity [rad/s],
# film volume [m3] when the YADE build has LiqControl's State.Vf, else 0).
# Contacts: every real sphere-sphere interaction: ids, gap = -penetrationDepth [m], the magnitude of
# the normal force YADE applied [N], whether the liquid bridge is active (separated, s < s_crit),
# its volume Vb [m3].
def granalytics_export(prefix):
    step = O.iter
    with open("%s_particles_%09d.csv" % (prefix, step), "w") as f:
        f.write("# time_s=%.17g step=%d dt_s=%.17g\n" % (O.time, step, O.dt))
        f.write("id,radius,x,y,z,vx,vy,vz,wx,wy,wz,film_volume\n")
        for b in O.bodies:
            if b is None or not isinstance(b.shape, Sphere):
                continue
            p, v, w = b.state.pos, b.state.vel, b.state.angVel
            film = getattr(b.state, "Vf", 0.0)
            f.write("%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n"
                    % (b.id, b.shape.radius, p[0], p[1], p[2], v[0], v[1], v[2], w[0], w[1], w[2], film))
    with open("%s_contacts_%09d.csv" % (prefix, step), "w") as f:
        f.write("# time_s=%.17g step=%d\n" % (O.time, step))
        f.write("id1,id2,gap,normal_force,bridge_active,bridge_volume\n")
        for i in O.interactions:
            if not i.isReal:
                continue
            if not (isinstance(O.bodies[i.id1].shape, Sphere) and isinstance(O.bodies[i.id2].shape, Sphere)):
                continue
            f.write("%d,%d,%.17g,%.17g,%d,%.17g\n" % (i.id1, i.id2, -i.geom.penetrationDepth, i.phys.normalForce.norm(),
                                                    int(i.phys.liqBridgeActive), i.phys.Vb))
