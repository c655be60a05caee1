//! The per-grain table of a snapshot.

use crate::error::Result;
use crate::table::{write_csv_atomic, CsvTable};
use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::snapshot::Snapshot;
use std::path::Path;

const AXES: [&str; 3] = ["x", "y", "z"];

/// Appends one column per component of `values`: `{prefix}x`, `{prefix}y`, … — or just `single`
/// when the values are scalars (`LEN == 1`).
fn push_components<V: VectorOps>(t: &mut CsvTable, prefix: &str, single: &str, values: &[V]) -> Result<()> {
    if V::LEN == 1 {
        return t.push_f64(single, values.iter().map(|v| v.get(0)));
    }
    for (k, axis) in AXES.iter().enumerate().take(V::LEN) {
        t.push_f64(format!("{prefix}{axis}"), values.iter().map(|v| v.get(k)))?;
    }
    Ok(())
}

/// One row per grain of `snapshot`, in storage order, with the columns
///
/// | dimension | columns |
/// |---|---|
/// | 2D | `id, x, y, vx, vy, omega, radius, mass, fx, fy` |
/// | 3D | `id, x, y, z, vx, vy, vz, omega_x, omega_y, omega_z, radius, mass, fx, fy, fz` |
///
/// `id` is the stable grain id; positions are wrapped into the periodic cell; `omega` is the
/// angular velocity (about ẑ in 2D); `fx, fy, fz` is the total force of the last force evaluation
/// (contacts, gravity and external loads), which vanishes at static equilibrium.
///
/// Fails only if the snapshot's per-grain arrays have different lengths (a snapshot taken with
/// [`Simulation::snapshot`](grainwave_core::sim::Simulation::snapshot) never does).
pub fn grains_csv<D: Dim>(snapshot: &Snapshot<D>) -> Result<CsvTable> {
    let s = snapshot;
    let mut t = CsvTable::new();
    t.push_u32("id", s.id.iter().copied())?;
    push_components(&mut t, "", "x", &s.pos)?;
    push_components(&mut t, "v", "vx", &s.vel)?;
    push_components(&mut t, "omega_", "omega", &s.omega)?;
    t.push_f64("radius", s.radius.iter().copied())?;
    t.push_f64("mass", s.mass.iter().copied())?;
    push_components(&mut t, "f", "fx", &s.force)?;
    Ok(t)
}

/// Writes [`grains_csv`] of `snapshot` to `path`, atomically; parent directories are created.
pub fn write_grains_csv<D: Dim>(path: &Path, snapshot: &Snapshot<D>) -> Result<()> {
    write_csv_atomic(path, &grains_csv(snapshot)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::tests::{parse_csv, scratch_dir};
    use glam::{DVec2, DVec3};
    use grainwave_core::prelude::*;

    fn law() -> ContactLaw {
        let mut p = ContactParams::preset("hooke_cundall_strack");
        p.normal_stiffness = Some(1e4);
        p.restitution = Some(0.5);
        p.build(Partner::Grain, "contact").unwrap()
    }

    /// Reads `path` back and checks every column against the snapshot, bit for bit.
    fn check_file<D: Dim>(path: &std::path::Path, s: &Snapshot<D>, header: &[&str]) {
        let rows = parse_csv(&std::fs::read_to_string(path).unwrap());
        assert_eq!(rows[0], header);
        assert_eq!(rows.len(), s.len() + 1);
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        let num = |row: &Vec<String>, name: &str| row[col(name)].parse::<f64>().unwrap();
        for (k, row) in rows[1..].iter().enumerate() {
            assert_eq!(row.len(), header.len());
            assert_eq!(row[0].parse::<u32>().unwrap(), s.id[k]);
            for (a, axis) in AXES.iter().enumerate().take(D::D) {
                assert_eq!(num(row, axis), s.pos[k].get(a));
                assert_eq!(num(row, &format!("v{axis}")), s.vel[k].get(a));
                assert_eq!(num(row, &format!("f{axis}")), s.force[k].get(a));
            }
            assert_eq!(num(row, "radius"), s.radius[k]);
            assert_eq!(num(row, "mass"), s.mass[k]);
        }
    }

    #[test]
    fn two_dimensional_columns_and_values() {
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        grains.push(DVec2::new(-0.6, 0.1), 0.5, 1.0, DVec2::new(1.0, 0.0));
        grains.push(DVec2::new(0.395, 0.1), 0.5, 2.0, DVec2::new(-1.0, 0.0));
        grains.omega[1] = 0.75;
        let domain = Domain::new(DVec2::new(-5.0, -5.0), DVec2::new(5.0, 5.0), [false; 3]);
        let sim = SimulationBuilder::new(grains, domain, law()).gravity(DVec2::new(0.0, -1.0)).build().unwrap();
        let snap = sim.snapshot();
        let header = ["id", "x", "y", "vx", "vy", "omega", "radius", "mass", "fx", "fy"];
        assert_eq!(grains_csv(&snap).unwrap().names(), header);
        let dir = scratch_dir("grains-2d");
        let path = dir.join("grains.csv");
        write_grains_csv(&path, &snap).unwrap();
        check_file(&path, &snap, &header);
        let rows = parse_csv(&std::fs::read_to_string(&path).unwrap());
        assert_eq!(rows[2][5], "0.75");
        assert_eq!(rows[1][6], "0.5");
        // The two disks overlap by 0.005 along x: the contact pushes them apart, gravity pulls down.
        let fx0: f64 = rows[1][8].parse().unwrap();
        assert!(fx0 < 0.0, "grain 0 is pushed towards −x: {fx0}");
        // Grain 1 spins counter-clockwise, so its surface at the contact moves down (−ŷ) and
        // friction drags grain 0 down in addition to its weight.
        let fy0: f64 = rows[1][9].parse().unwrap();
        assert!(fy0 < -snap.mass[0], "fy = {fy0}, weight {}", snap.mass[0]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn three_dimensional_columns_and_values() {
        let mut grains = Grains::<D3>::new(GrainKind::Sphere);
        grains.push(DVec3::new(0.0, 0.0, 0.0), 0.5, 1.0, DVec3::new(0.1, 0.2, 0.3));
        grains.push(DVec3::new(2.0, 0.0, 1.0), 0.4, 1.0, DVec3::ZERO);
        grains.omega[0] = DVec3::new(1.0, -2.0, 3.0);
        let domain = Domain::new(DVec3::splat(-5.0), DVec3::splat(5.0), [false; 3]);
        let sim = SimulationBuilder::new(grains, domain, law()).build().unwrap();
        let snap = sim.snapshot();
        let header = ["id", "x", "y", "z", "vx", "vy", "vz", "omega_x", "omega_y", "omega_z", "radius", "mass", "fx", "fy", "fz"];
        assert_eq!(grains_csv(&snap).unwrap().names(), header);
        let dir = scratch_dir("grains-3d");
        let path = dir.join("grains.csv");
        write_grains_csv(&path, &snap).unwrap();
        check_file(&path, &snap, &header);
        let rows = parse_csv(&std::fs::read_to_string(&path).unwrap());
        assert_eq!(&rows[1][7..10], ["1.0", "-2.0", "3.0"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn malformed_snapshot_is_an_error_not_a_panic() {
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        grains.push(DVec2::ZERO, 0.5, 1.0, DVec2::ZERO);
        let domain = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3]);
        let mut snap = SimulationBuilder::new(grains, domain, law()).build().unwrap().snapshot();
        snap.mass.push(1.0);
        let err = grains_csv(&snap).unwrap_err();
        assert!(err.to_string().contains("`mass`"), "{err}");
    }
}
