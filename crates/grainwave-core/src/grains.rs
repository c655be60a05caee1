//! Grains: kinds, inertia, structure-of-arrays storage with stable ids, size distributions.

use crate::dim::{Dim, VectorOps};
use crate::error::{require_positive, CoreError, Result};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The shape and inertia convention of the grains of a simulation (SPEC §1.1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GrainKind {
    /// 2D disk: m = ρ π R² W, I = ½ m R² (W = thickness; W = 1 means "per unit thickness").
    Disk {
        /// Thickness W (length units).
        thickness: f64,
    },
    /// 3D sphere whose centre is confined to a plane: m = ρ (4/3) π R³, I = (2/5) m R².
    Sphere2d,
    /// 3D sphere: m = ρ (4/3) π R³, I = (2/5) m R².
    Sphere,
}

impl GrainKind {
    /// Parses `disk`, `sphere2d` or `sphere` (disks get thickness 1).
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "disk" => Ok(GrainKind::Disk { thickness: 1.0 }),
            "sphere2d" => Ok(GrainKind::Sphere2d),
            "sphere" => Ok(GrainKind::Sphere),
            _ => Err(CoreError::UnknownName {
                what: "grain kind".into(),
                name: name.into(),
                available: "disk, sphere2d, sphere".into(),
            }),
        }
    }

    /// Name as used in configs.
    pub fn name(&self) -> &'static str {
        match self {
            GrainKind::Disk { .. } => "disk",
            GrainKind::Sphere2d => "sphere2d",
            GrainKind::Sphere => "sphere",
        }
    }

    /// Dimension of the grains' centres (2 for `disk`, `sphere2d`; 3 for `sphere`).
    pub fn dimension(&self) -> usize {
        match self {
            GrainKind::Disk { .. } | GrainKind::Sphere2d => 2,
            GrainKind::Sphere => 3,
        }
    }

    /// Mass of a grain of radius `r` and density `rho`.
    pub fn mass(&self, r: f64, rho: f64) -> f64 {
        match self {
            GrainKind::Disk { thickness } => rho * PI * r * r * thickness,
            GrainKind::Sphere2d | GrainKind::Sphere => rho * 4.0 / 3.0 * PI * r * r * r,
        }
    }

    /// Moment of inertia of a grain of mass `m` and radius `r` about its centre.
    pub fn inertia(&self, m: f64, r: f64) -> f64 {
        match self {
            GrainKind::Disk { .. } => 0.5 * m * r * r,
            GrainKind::Sphere2d | GrainKind::Sphere => 0.4 * m * r * r,
        }
    }

    /// "Volume" used for solid fractions: area π R² for disks, volume (4/3) π R³ for spheres.
    pub fn measure(&self, r: f64) -> f64 {
        match self {
            GrainKind::Disk { .. } => PI * r * r,
            GrainKind::Sphere2d | GrainKind::Sphere => 4.0 / 3.0 * PI * r * r * r,
        }
    }

    /// Checks parameters and that the kind fits dimension `dim`.
    pub fn validate(&self, dim: usize) -> Result<()> {
        if let GrainKind::Disk { thickness } = self {
            require_positive("grains.thickness", *thickness)?;
        }
        if self.dimension() != dim {
            return Err(CoreError::Inconsistent(format!(
                "grain kind `{}` lives in {}D but the simulation is {}D",
                self.name(),
                self.dimension(),
                dim
            )));
        }
        Ok(())
    }
}

/// Distribution of grain radii (SPEC §1.2). All draws use the simulation's seeded generator.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SizeDistribution {
    /// Every grain has radius `radius`.
    Monodisperse {
        /// Radius (length).
        radius: f64,
    },
    /// Diameter uniform in [d̄(1−a), d̄(1+a)].
    UniformDiameter {
        /// Mean diameter d̄.
        mean_diameter: f64,
        /// Relative half-width a ∈ [0, 1).
        spread: f64,
    },
    /// Radius uniform in [R̄(1−δ), R̄] (R̄ is the largest radius).
    UniformRadius {
        /// Largest radius R̄.
        max_radius: f64,
        /// Relative width δ ∈ [0, 1).
        delta: f64,
    },
    /// An explicit list of radii, used in order (cycled if shorter than the grain count).
    Explicit {
        /// Radii.
        radii: Vec<f64>,
    },
}

/// Smallest and largest radius a grain may have [length]: masses and moments of inertia go as
/// R⁵ at most (a sphere's I = 2/5 ρ (4/3 π) R⁵), which must stay a normal, finite f64
/// (1e-60⁵ = 1e-300 > 2.2e-308, 1e60⁵ = 1e300 < 1.8e308). A radius outside, such as the 0 that
/// `mean_diameter = 5e-324` rounds to, would give zero or infinite masses and cell sizes that
/// placement cannot grow from.
pub const RADIUS_RANGE: (f64, f64) = (1e-60, 1e60);

/// Checks that radius `r`, which `field = value` gives (itself, or the smallest or largest radius
/// it allows), is in [`RADIUS_RANGE`].
fn require_radius(field: &str, value: f64, r: f64, what: &str) -> Result<()> {
    let (lo, hi) = RADIUS_RANGE;
    if r.is_finite() && r >= lo && r <= hi {
        Ok(())
    } else {
        Err(CoreError::invalid(field, format!("{value:?}"), format!("{what} between {lo:e} and {hi:e}, here {r:?} (masses and moments of inertia ∝ R⁵ must be representable)")))
    }
}

impl SizeDistribution {
    /// Validates the parameters: every radius the distribution can draw lies in
    /// [`RADIUS_RANGE`].
    pub fn validate(&self) -> Result<()> {
        match self {
            SizeDistribution::Monodisperse { radius } => {
                require_positive("radius", *radius)?;
                require_radius("radius", *radius, *radius, "a radius")
            }
            SizeDistribution::UniformDiameter { mean_diameter, spread } => {
                require_positive("mean_diameter", *mean_diameter)?;
                if !(0.0..1.0).contains(spread) {
                    return Err(CoreError::invalid("spread", spread, "a number in [0, 1)"));
                }
                require_radius("mean_diameter", *mean_diameter, 0.5 * mean_diameter * (1.0 + spread), "a largest radius d̄(1 + a)/2")?;
                require_radius("mean_diameter", *mean_diameter, 0.5 * mean_diameter * (1.0 - spread), "a smallest radius d̄(1 − a)/2")
            }
            SizeDistribution::UniformRadius { max_radius, delta } => {
                require_positive("max_radius", *max_radius)?;
                if !(0.0..1.0).contains(delta) {
                    return Err(CoreError::invalid("delta", delta, "a number in [0, 1)"));
                }
                require_radius("max_radius", *max_radius, *max_radius, "a radius")?;
                require_radius("max_radius", *max_radius, max_radius * (1.0 - delta), "a smallest radius R̄(1 − δ)")
            }
            SizeDistribution::Explicit { radii } => {
                if radii.is_empty() {
                    return Err(CoreError::invalid("radii", "[]", "a non-empty list of radii > 0"));
                }
                for (k, r) in radii.iter().enumerate() {
                    require_positive(&format!("radii[{k}]"), *r)?;
                    require_radius(&format!("radii[{k}]"), *r, *r, "a radius")?;
                }
                Ok(())
            }
        }
    }

    /// Draws `n` radii.
    pub fn sample(&self, n: usize, rng: &mut ChaCha8Rng) -> Result<Vec<f64>> {
        self.validate()?;
        Ok(match self {
            SizeDistribution::Monodisperse { radius } => vec![*radius; n],
            SizeDistribution::UniformDiameter { mean_diameter, spread } => (0..n)
                .map(|_| 0.5 * mean_diameter * (1.0 + spread * (2.0 * rng.random::<f64>() - 1.0)))
                .collect(),
            SizeDistribution::UniformRadius { max_radius, delta } => {
                (0..n).map(|_| max_radius * (1.0 - delta * rng.random::<f64>())).collect()
            }
            SizeDistribution::Explicit { radii } => (0..n).map(|k| radii[k % radii.len()]).collect(),
        })
    }

    /// Largest radius the distribution can produce.
    pub fn max_radius(&self) -> f64 {
        match self {
            SizeDistribution::Monodisperse { radius } => *radius,
            SizeDistribution::UniformDiameter { mean_diameter, spread } => 0.5 * mean_diameter * (1.0 + spread),
            SizeDistribution::UniformRadius { max_radius, .. } => *max_radius,
            SizeDistribution::Explicit { radii } => radii.iter().cloned().fold(0.0, f64::max),
        }
    }
}

/// Grains stored as structure of arrays. Index `k` is the storage slot; `id[k]` is the stable id
/// that survives re-ordering and appears in every output.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Grains<D: Dim> {
    /// Shape and inertia convention.
    pub kind: GrainKind,
    /// Stable ids.
    pub id: Vec<u32>,
    /// Radii R (length).
    pub radius: Vec<f64>,
    /// Masses m.
    pub mass: Vec<f64>,
    /// Moments of inertia I.
    pub inertia: Vec<f64>,
    /// Positions of the centres, wrapped into the periodic cell along periodic axes.
    pub pos: Vec<D::Vector>,
    /// Translational velocities.
    pub vel: Vec<D::Vector>,
    /// Angular velocities.
    pub omega: Vec<D::AngVector>,
    /// Orientations.
    pub orientation: Vec<D::Orientation>,
    /// Periodic image counters: how many times each grain crossed each periodic axis.
    pub image: Vec<[i32; 3]>,
    /// Total force of the last force evaluation (contacts + body + external).
    pub force: Vec<D::Vector>,
    /// Total torque of the last force evaluation.
    pub torque: Vec<D::AngVector>,
}

impl<D: Dim> Grains<D> {
    /// Empty storage for grains of `kind`.
    pub fn new(kind: GrainKind) -> Self {
        Grains {
            kind,
            id: Vec::new(),
            radius: Vec::new(),
            mass: Vec::new(),
            inertia: Vec::new(),
            pos: Vec::new(),
            vel: Vec::new(),
            omega: Vec::new(),
            orientation: Vec::new(),
            image: Vec::new(),
            force: Vec::new(),
            torque: Vec::new(),
        }
    }

    /// Number of grains.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True when there are no grains.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Appends a grain of radius `radius` and density `density` at `pos`, with velocity `vel`;
    /// its id is the current count. Returns the id.
    pub fn push(&mut self, pos: D::Vector, radius: f64, density: f64, vel: D::Vector) -> u32 {
        let m = self.kind.mass(radius, density);
        self.push_with_mass(pos, radius, m, vel)
    }

    /// Appends a grain with an explicit mass (moment of inertia from the kind). Returns the id.
    pub fn push_with_mass(&mut self, pos: D::Vector, radius: f64, mass: f64, vel: D::Vector) -> u32 {
        let id = self.id.len() as u32;
        self.id.push(id);
        self.radius.push(radius);
        self.mass.push(mass);
        self.inertia.push(self.kind.inertia(mass, radius));
        self.pos.push(pos);
        self.vel.push(vel);
        self.omega.push(D::AngVector::ZERO);
        self.orientation.push(D::identity_orientation());
        self.image.push([0; 3]);
        self.force.push(D::Vector::ZERO);
        self.torque.push(D::AngVector::ZERO);
        id
    }

    /// Storage index of the grain with stable id `id`, if present.
    pub fn index_of(&self, id: u32) -> Option<usize> {
        // Ids are assigned as 0..n and storage is only permuted, so a direct hit is the usual case.
        let guess = id as usize;
        if guess < self.id.len() && self.id[guess] == id {
            return Some(guess);
        }
        self.id.iter().position(|&x| x == id)
    }

    /// Total mass.
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// Translational + rotational kinetic energy, summed in a fixed order.
    pub fn kinetic_energy(&self) -> f64 {
        let mut e = 0.0;
        for k in 0..self.len() {
            e += 0.5 * self.mass[k] * self.vel[k].norm2() + 0.5 * self.inertia[k] * self.omega[k].norm2();
        }
        e
    }

    /// Smallest and largest radius (0, 0 when empty).
    pub fn radius_range(&self) -> (f64, f64) {
        if self.radius.is_empty() {
            return (0.0, 0.0);
        }
        self.radius.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), &r| (lo.min(r), hi.max(r)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn inertia_matches_table() {
        let disk = GrainKind::Disk { thickness: 2.0 };
        let m = disk.mass(0.5, 3.0);
        assert!((m - 3.0 * PI * 0.25 * 2.0).abs() < 1e-14);
        assert!((disk.inertia(m, 0.5) - 0.5 * m * 0.25).abs() < 1e-14);
        let s = GrainKind::Sphere;
        let m = s.mass(0.5, 1.0);
        assert!((m - PI / 6.0).abs() < 1e-14);
        assert!((s.inertia(m, 0.5) - 0.4 * m * 0.25).abs() < 1e-14);
        assert_eq!(GrainKind::Sphere2d.mass(0.5, 1.0), m);
    }

    #[test]
    fn size_distributions_respect_bounds() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let d = SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 0.2 };
        let r = d.sample(10_000, &mut rng).unwrap();
        assert!(r.iter().all(|&x| (0.4..=0.6).contains(&x)));
        let mean: f64 = r.iter().sum::<f64>() / r.len() as f64;
        assert!((mean - 0.5).abs() < 0.005, "mean radius {mean}");
        let d = SizeDistribution::UniformRadius { max_radius: 1.0, delta: 0.25 };
        let r = d.sample(10_000, &mut rng).unwrap();
        assert!(r.iter().all(|&x| (0.75..=1.0).contains(&x)));
        assert!(SizeDistribution::Monodisperse { radius: -1.0 }.validate().is_err());
        // radii whose R⁵ (masses, moments of inertia) is not a normal finite number are refused,
        // by the smallest and the largest radius a distribution can draw
        for (d, ok) in [
            (SizeDistribution::UniformDiameter { mean_diameter: 5e-324, spread: 0.0 }, false),
            (SizeDistribution::UniformDiameter { mean_diameter: 1e-50, spread: 0.5 }, true),
            (SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 1.0 - 1e-70 }, false),
            (SizeDistribution::UniformRadius { max_radius: 1e61, delta: 0.0 }, false),
            (SizeDistribution::UniformRadius { max_radius: 1e59, delta: 0.5 }, true),
            (SizeDistribution::Monodisperse { radius: 1e-61 }, false),
            (SizeDistribution::Explicit { radii: vec![1.0, 1e-65] }, false),
        ] {
            assert_eq!(d.validate().is_ok(), ok, "{d:?}");
        }
        let e = SizeDistribution::UniformDiameter { mean_diameter: 5e-324, spread: 0.0 }.validate().unwrap_err().to_string();
        assert!(e.contains("mean_diameter") && e.contains("5e-324") && e.contains("between 1e-60 and 1e60"), "{e}");
    }
}
