//! VTK datasets of a snapshot: the grains as points, the contact network as lines.

use super::dataset::{VtkCells, VtkDataSet, VtkFormat, VtkValues};
use crate::error::{OutputError, Result};
use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::snapshot::{Counterpart, Snapshot};
use std::collections::HashMap;
use std::path::Path;

/// An angular vector as three components: a 2D scalar ω about ẑ becomes (0, 0, ω).
fn ang3<V: VectorOps>(w: V) -> [f64; 3] {
    if V::LEN == 1 {
        [0.0, 0.0, w.get(0)]
    } else {
        w.to_array3()
    }
}

fn vectors(values: impl Iterator<Item = [f64; 3]>) -> VtkValues {
    VtkValues::Float64(values.flatten().collect())
}

/// Checks that every per-grain array of the snapshot has one entry per grain.
fn check_lengths<D: Dim>(s: &Snapshot<D>) -> Result<()> {
    let n = s.id.len();
    let lengths = [
        ("radius", s.radius.len()),
        ("mass", s.mass.len()),
        ("pos", s.pos.len()),
        ("vel", s.vel.len()),
        ("omega", s.omega.len()),
        ("rotation", s.rotation.len()),
        ("force", s.force.len()),
        ("torque", s.torque.len()),
    ];
    for (name, len) in lengths {
        if len != n {
            return Err(OutputError::Length { what: format!("snapshot field `{name}` (one value per grain)"), expected: n, len });
        }
    }
    Ok(())
}

/// The grains of `snapshot` as a dataset: one point per grain at its centre (z = 0 in 2D) and
/// one vertex cell per grain, in storage order, with the point arrays
///
/// | name | type | components | meaning |
/// |---|---|---|---|
/// | `id` | Int64 | 1 | stable grain id |
/// | `radius` | Float64 | 1 | radius R |
/// | `mass` | Float64 | 1 | mass m |
/// | `velocity` | Float64 | 3 | velocity (v_z = 0 in 2D) |
/// | `angular_velocity` | Float64 | 3 | angular velocity; 2D: (0, 0, ω) |
/// | `force` | Float64 | 3 | total force of the last force evaluation |
/// | `torque` | Float64 | 3 | total torque; 2D: (0, 0, τ) |
/// | `rotation` | Float64 | 3 | orientation as a rotation vector (axis × angle); 2D: (0, 0, θ) |
///
/// in the units of the simulation; the snapshot's time is stored as `TimeValue`. In ParaView,
/// show the points with the *Point Gaussian* representation scaled by `radius` (or a *Glyph*
/// filter with sphere glyphs scaled by `radius`, scale factor 2) to see the grains.
pub fn grains_dataset<D: Dim>(snapshot: &Snapshot<D>) -> Result<VtkDataSet> {
    let s = snapshot;
    check_lengths(s)?;
    let n = s.len();
    let points = s.pos.iter().map(|p| p.to_array3()).collect();
    let mut d = VtkDataSet::new(points, VtkCells::Vertices((0..n as u64).collect()))?;
    d.set_time(s.time);
    d.push_point_data("id", 1, VtkValues::Int64(s.id.iter().map(|&i| i64::from(i)).collect()))?;
    d.push_point_data("radius", 1, VtkValues::Float64(s.radius.clone()))?;
    d.push_point_data("mass", 1, VtkValues::Float64(s.mass.clone()))?;
    d.push_point_data("velocity", 3, vectors(s.vel.iter().map(|v| v.to_array3())))?;
    d.push_point_data("angular_velocity", 3, vectors(s.omega.iter().map(|&w| ang3(w))))?;
    d.push_point_data("force", 3, vectors(s.force.iter().map(|f| f.to_array3())))?;
    d.push_point_data("torque", 3, vectors(s.torque.iter().map(|&t| ang3(t))))?;
    d.push_point_data("rotation", 3, vectors(s.rotation.iter().copied()))?;
    Ok(d)
}

/// The contact network of `snapshot` as a dataset: one line cell per contact record, in the
/// snapshot's order.
///
/// Points: first the centres of all grains in storage order (point k is grain `id[k]`), then
/// extra points: for a grain–wall contact, the contact point on the wall (centre of i + branch);
/// for a grain–grain contact through a periodic boundary, the periodic image of j next to i
/// (centre of i + branch), so that the line is drawn across the contact and not across the box.
/// A line runs from the centre of i to the centre of j or to that extra point. Point array: `id`
/// (Int64), the grain a point belongs to, −1 for contact points on walls.
///
/// Cell arrays (2D vectors get z = 0):
///
/// | name | type | components | meaning |
/// |---|---|---|---|
/// | `normal_force` | Float64 | 1 | F_n ≥ 0, repulsive (elastic + damping) |
/// | `tangential_force` | Float64 | 3 | tangential force on i |
/// | `force` | Float64 | 3 | total contact force on i, −F_n n̂ + F_t |
/// | `normal` | Float64 | 3 | unit normal n̂ from i towards j (or the wall) |
/// | `branch` | Float64 | 3 | centre of i to centre of j (nearest image) or to the wall contact point |
/// | `overlap` | Float64 | 1 | overlap ξ |
/// | `normal_stiffness` | Float64 | 1 | k_n = dF_n/dξ |
/// | `tangential_stiffness` | Float64 | 1 | k_t |
/// | `sliding` | UInt8 | 1 | 1 if the Coulomb limit is reached |
/// | `wall` | Int32 | 1 | wall index, −1 for grain–grain contacts |
/// | `i` | Int64 | 1 | id of grain i |
/// | `j` | Int64 | 1 | id of grain j, −1 for wall contacts |
///
/// Fails if a contact names a grain id that is not in the snapshot.
pub fn contacts_dataset<D: Dim>(snapshot: &Snapshot<D>) -> Result<VtkDataSet> {
    let s = snapshot;
    check_lengths(s)?;
    let index: HashMap<u32, usize> = s.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    let lookup = |id: u32| index.get(&id).copied().ok_or(OutputError::UnknownGrain(id));
    let mut points: Vec<[f64; 3]> = s.pos.iter().map(|p| p.to_array3()).collect();
    let mut point_id: Vec<i64> = s.id.iter().map(|&i| i64::from(i)).collect();
    let mut lines = Vec::with_capacity(s.contacts.len());
    for c in &s.contacts {
        let i = lookup(c.i)?;
        let end = s.pos[i] + c.branch;
        let far = match c.j {
            Counterpart::Grain(j_id) => {
                let j = lookup(j_id)?;
                // Without wrapping, branch = pos_j − pos_i exactly; a periodic contact differs
                // from it by a whole cell length.
                let gap = (end - s.pos[j]).norm();
                if gap <= 1e-9 * (s.radius[i] + s.radius[j]) {
                    j as u64
                } else {
                    points.push(end.to_array3());
                    point_id.push(i64::from(j_id));
                    (points.len() - 1) as u64
                }
            }
            Counterpart::Wall(_) => {
                points.push(end.to_array3());
                point_id.push(-1);
                (points.len() - 1) as u64
            }
        };
        lines.push([i as u64, far]);
    }
    let mut d = VtkDataSet::new(points, VtkCells::Lines(lines))?;
    d.set_time(s.time);
    d.push_point_data("id", 1, VtkValues::Int64(point_id))?;
    let cs = &s.contacts;
    d.push_cell_data("normal_force", 1, VtkValues::Float64(cs.iter().map(|c| c.normal_force).collect()))?;
    d.push_cell_data("tangential_force", 3, vectors(cs.iter().map(|c| c.tangential_force.to_array3())))?;
    d.push_cell_data("force", 3, vectors(cs.iter().map(|c| c.force_on_i().to_array3())))?;
    d.push_cell_data("normal", 3, vectors(cs.iter().map(|c| c.normal.to_array3())))?;
    d.push_cell_data("branch", 3, vectors(cs.iter().map(|c| c.branch.to_array3())))?;
    d.push_cell_data("overlap", 1, VtkValues::Float64(cs.iter().map(|c| c.overlap).collect()))?;
    d.push_cell_data("normal_stiffness", 1, VtkValues::Float64(cs.iter().map(|c| c.normal_stiffness).collect()))?;
    d.push_cell_data("tangential_stiffness", 1, VtkValues::Float64(cs.iter().map(|c| c.tangential_stiffness).collect()))?;
    d.push_cell_data("sliding", 1, VtkValues::UInt8(cs.iter().map(|c| u8::from(c.sliding)).collect()))?;
    let wall = |c: &Counterpart| match *c {
        Counterpart::Wall(w) => w as i32,
        Counterpart::Grain(_) => -1,
    };
    d.push_cell_data("wall", 1, VtkValues::Int32(cs.iter().map(|c| wall(&c.j)).collect()))?;
    d.push_cell_data("i", 1, VtkValues::Int64(cs.iter().map(|c| i64::from(c.i)).collect()))?;
    let j = |c: &Counterpart| match *c {
        Counterpart::Grain(j) => i64::from(j),
        Counterpart::Wall(_) => -1,
    };
    d.push_cell_data("j", 1, VtkValues::Int64(cs.iter().map(|c| j(&c.j)).collect()))?;
    Ok(d)
}

/// Writes [`grains_dataset`] of `snapshot` to `path` (which must end in `.vtp`) as VTK
/// PolyData, atomically; parent directories are created.
pub fn write_grains_vtp<D: Dim>(path: &Path, snapshot: &Snapshot<D>) -> Result<()> {
    grains_dataset(snapshot)?.write_as(path, VtkFormat::PolyData)
}

/// Writes [`contacts_dataset`] of `snapshot` to `path` (which must end in `.vtp`) as VTK
/// PolyData, atomically; parent directories are created.
pub fn write_contacts_vtp<D: Dim>(path: &Path, snapshot: &Snapshot<D>) -> Result<()> {
    contacts_dataset(snapshot)?.write_as(path, VtkFormat::PolyData)
}

/// Writes [`grains_dataset`] of `snapshot` to `path` (which must end in `.vtu`) as a VTK
/// UnstructuredGrid of vertex cells, atomically — the same content as [`write_grains_vtp`] in
/// the dataset type that `meshio` also reads.
pub fn write_grains_vtu<D: Dim>(path: &Path, snapshot: &Snapshot<D>) -> Result<()> {
    grains_dataset(snapshot)?.write_as(path, VtkFormat::UnstructuredGrid)
}

/// Writes [`contacts_dataset`] of `snapshot` to `path` (which must end in `.vtu`) as a VTK
/// UnstructuredGrid of line cells, atomically — the same content as [`write_contacts_vtp`],
/// readable by `meshio` too.
pub fn write_contacts_vtu<D: Dim>(path: &Path, snapshot: &Snapshot<D>) -> Result<()> {
    contacts_dataset(snapshot)?.write_as(path, VtkFormat::UnstructuredGrid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vtk::dataset::tests::{array_bytes, f64s, i64s};
    use glam::{DVec2, DVec3};
    use grainwave_core::prelude::*;

    fn law(partner: Partner) -> ContactLaw {
        let mut p = ContactParams::preset("hooke_cundall_strack");
        p.normal_stiffness = Some(1e4);
        p.restitution = Some(0.5);
        p.build(partner, "contact").unwrap()
    }

    /// Three disks of radius 0.5 in a cell periodic along x ([0, 4)) above a floor at y = 0:
    /// grain 0 at x = 0.2 touches grain 1 at x = 3.205 through the periodic boundary (centre
    /// distance 0.995), both press on the floor, and grain 2 sits on grain 0.
    pub(crate) fn periodic_pile() -> Snapshot<D2> {
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        grains.push(DVec2::new(0.2, 0.495), 0.5, 1.0, DVec2::ZERO);
        grains.push(DVec2::new(3.205, 0.495), 0.5, 1.0, DVec2::new(0.1, 0.0));
        grains.push(DVec2::new(0.2, 1.49), 0.5, 1.0, DVec2::ZERO);
        grains.omega[2] = 0.25;
        let floor = Wall::axis_aligned("floor", 1, 0.0, true, law(Partner::Wall));
        let domain = Domain::new(DVec2::new(0.0, 0.0), DVec2::new(4.0, 4.0), [true, false, false]).with_wall(floor);
        SimulationBuilder::new(grains, domain, law(Partner::Grain)).build().unwrap().snapshot()
    }

    #[test]
    fn grains_points_and_arrays_2d() {
        let s = periodic_pile();
        let d = grains_dataset(&s).unwrap();
        assert_eq!(d.points().len(), 3);
        assert_eq!(d.points()[1], [3.205, 0.495, 0.0]);
        assert_eq!(d.cells(), &VtkCells::Vertices(vec![0, 1, 2]));
        let names: Vec<_> = d.point_data().iter().map(|a| (a.name.as_str(), a.components)).collect();
        assert_eq!(
            names,
            [("id", 1), ("radius", 1), ("mass", 1), ("velocity", 3), ("angular_velocity", 3), ("force", 3), ("torque", 3), ("rotation", 3)]
        );
        let xml = d.to_xml(VtkFormat::PolyData);
        assert_eq!(f64s(&array_bytes(&xml, "PointData", "angular_velocity")), [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25]);
        assert_eq!(f64s(&array_bytes(&xml, "PointData", "velocity"))[3..6], [0.1, 0.0, 0.0]);
        let force = f64s(&array_bytes(&xml, "PointData", "force"));
        assert_eq!(force[..2], [s.force[0].x, s.force[0].y]);
        assert_eq!(force[2], 0.0);
        assert_eq!(f64s(&array_bytes(&xml, "FieldData", "TimeValue")), [s.time]);
    }

    #[test]
    fn contacts_through_periodic_boundary_and_walls_get_their_own_points() {
        let s = periodic_pile();
        let d = contacts_dataset(&s).unwrap();
        let VtkCells::Lines(lines) = d.cells() else { panic!("lines expected") };
        // Contacts: 0–1 (periodic), 0–2, and 0 and 1 on the floor.
        assert_eq!(lines.len(), 4, "{:?}", s.contacts);
        assert_eq!(d.points().len(), 3 + 3, "one periodic image and two wall points");
        for (c, line) in s.contacts.iter().zip(lines) {
            let i = s.id.iter().position(|&id| id == c.i).unwrap();
            assert_eq!(line[0], i as u64);
            let far = d.points()[line[1] as usize];
            let expected = s.pos[i] + c.branch;
            assert!((far[0] - expected.x).abs() < 1e-12 && (far[1] - expected.y).abs() < 1e-12, "{far:?} vs {expected:?}");
            let length = ((far[0] - s.pos[i].x).powi(2) + (far[1] - s.pos[i].y).powi(2)).sqrt();
            assert!(length < 1.0, "lines span the contact, not the box: {length}");
            match c.j {
                Counterpart::Wall(_) => assert!(far[1].abs() < 1e-12, "wall contact point on the floor: {far:?}"),
                Counterpart::Grain(j) if (s.pos[i].x - s.pos[j as usize].x).abs() > 2.0 => {
                    assert!(line[1] >= 3, "periodic contact drawn to an image point");
                    assert!(far[0] < 0.0 || far[0] > 4.0, "image lies outside the cell: {far:?}");
                }
                Counterpart::Grain(j) => assert_eq!(line[1], j as u64),
            }
        }
        let xml = d.to_xml(VtkFormat::UnstructuredGrid);
        let walls: Vec<i32> = array_bytes(&xml, "CellData", "wall").chunks(4).map(|b| i32::from_le_bytes(b.try_into().unwrap())).collect();
        assert_eq!(walls.iter().filter(|&&w| w == 0).count(), 2);
        assert_eq!(walls.iter().filter(|&&w| w == -1).count(), 2);
        let j = i64s(&array_bytes(&xml, "CellData", "j"));
        assert!(walls.iter().zip(&j).all(|(&w, &j)| (w == -1) == (j >= 0)));
        let fn_ = f64s(&array_bytes(&xml, "CellData", "normal_force"));
        let force = f64s(&array_bytes(&xml, "CellData", "force"));
        for (k, c) in s.contacts.iter().enumerate() {
            assert!(fn_[k] > 0.0);
            assert_eq!(fn_[k], c.normal_force);
            assert_eq!(force[3 * k..3 * k + 2], [c.force_on_i().x, c.force_on_i().y]);
        }
        let ids = i64s(&array_bytes(&xml, "PointData", "id"));
        assert_eq!(ids[..3], [0, 1, 2]);
        assert_eq!(ids[3..].iter().filter(|&&i| i == -1).count(), 2);
    }

    #[test]
    fn three_dimensional_snapshot() {
        let mut grains = Grains::<D3>::new(GrainKind::Sphere);
        grains.push(DVec3::new(0.0, 0.0, 0.0), 0.5, 1.0, DVec3::new(0.0, 0.0, -1.0));
        grains.push(DVec3::new(0.0, 0.0, 0.995), 0.5, 1.0, DVec3::ZERO);
        grains.omega[0] = DVec3::new(1.0, 2.0, 3.0);
        let domain = Domain::new(DVec3::splat(-5.0), DVec3::splat(5.0), [false; 3]);
        let s = SimulationBuilder::new(grains, domain, law(Partner::Grain)).build().unwrap().snapshot();
        let g = grains_dataset(&s).unwrap().to_xml(VtkFormat::PolyData);
        assert_eq!(f64s(&array_bytes(&g, "PointData", "angular_velocity"))[..3], [1.0, 2.0, 3.0]);
        assert_eq!(f64s(&array_bytes(&g, "Points", "Points"))[3..], [0.0, 0.0, 0.995]);
        let c = contacts_dataset(&s).unwrap();
        assert_eq!(c.cells(), &VtkCells::Lines(vec![[0, 1]]));
        assert_eq!(c.points().len(), 2);
        let normal = f64s(&array_bytes(&c.to_xml(VtkFormat::PolyData), "CellData", "normal"));
        assert_eq!(normal, [0.0, 0.0, 1.0]);
    }

    #[test]
    fn unknown_grain_and_bad_extension_are_errors() {
        let mut s = periodic_pile();
        s.contacts[0].i = 99;
        assert!(matches!(contacts_dataset(&s), Err(OutputError::UnknownGrain(99))));
        let s = periodic_pile();
        let dir = crate::table::tests::scratch_dir("vtk-ext");
        assert!(write_grains_vtp(&dir.join("g.vtu"), &s).is_err());
        write_grains_vtp(&dir.join("g.vtp"), &s).unwrap();
        write_contacts_vtu(&dir.join("c.vtu"), &s).unwrap();
        assert!(std::fs::read_to_string(dir.join("g.vtp")).unwrap().contains("type=\"PolyData\""));
        assert!(std::fs::read_to_string(dir.join("c.vtu")).unwrap().contains("type=\"UnstructuredGrid\""));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
