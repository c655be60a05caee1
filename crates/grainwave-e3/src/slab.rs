//! Construction of E3 packings (SPEC §7.2.1, §7.2.9): lattice sites of a slab or a pile, radii,
//! contact laws and the engine simulation.
//!
//! **Units** (SPEC §7.1): R̄ = 1 (the largest radius), g = 1, and the disks have thickness 1 and
//! density 1/π, so that a disk of radius R has mass m = R² and m̄ = 1; τ = √(R̄/g) = 1.
//!
//! **Slab.** L rows on a triangular lattice of spacing 2R̄ (rows √3 R̄ apart, the lowest at height
//! R̄ above the floor), between side walls at x = 0 and x = W. With `rows = "full"` (default, SPEC
//! §7.2.1) every row holds M grains, the even rows (0 = bottom) at x = R̄, 3R̄, …, (2M − 1)R̄ and the
//! odd ones at 2R̄, …, 2MR̄, W = (2M + 1)R̄: each row touches one side wall (the even rows the left,
//! the odd rows the right), the nearest centres of the other row parity being at 2R̄ from it; 15 × 60
//! gives 900 grains in a box 121 R̄ wide. The default load, the top-row grain nearest the box's axis
//! x = W/2, is then half a radius from the axis (x = 61 for 15 × 60). With
//! `rows = "alternating_m_and_m_minus_1"` the rows hold M and M − 1 grains in turn, the long rows
//! at x = R̄, 3R̄, …, (2M − 1)R̄ and the short ones at x = 2R̄, …, (2M − 2)R̄, W = 2MR̄: the slab is
//! symmetric about x = MR̄ and every wall is at distance R̄ from the nearest centres; the parity is
//! chosen so that the top row has a grain on the axis (the top row is long when M is odd).
//!
//! **Pile.** Layer r (from the bottom) holds T + L − 1 − r grains centred on the axis (T the top
//! layer's count), each layer shifted by R̄; the bottom layer touches both side walls.
//!
//! Polydisperse grains keep their lattice centres (the spacing fits the largest radius) and settle
//! under gravity.

use super::config::{IntegrationConfig, IntegratorName, MaterialConfig, RowLayout};
use grainwave_study::Result;
use glam::DVec2;
use grainwave_core::contact::damping::normal::Dashpot;
use grainwave_core::contact::damping::tangential::Coefficient;
use grainwave_core::contact::tangential::Linear;
use grainwave_core::contact::{ContactLaw, Hooke, NormalElastic, Rolling, Tangential, TangentialDamping, Twisting};
use grainwave_core::prelude::*;
use grainwave_core::sim::Safety;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Disk density giving m = R² (m̄ = 1 for R̄ = 1, unit thickness).
pub const DENSITY: f64 = 1.0 / std::f64::consts::PI;
/// Index of the floor among the walls.
pub const FLOOR: u32 = 0;
/// Index of the left wall.
pub const LEFT: u32 = 1;
/// Index of the right wall.
pub const RIGHT: u32 = 2;

/// Shape of a packing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// A slab of `layers` rows of `grains_per_layer` grains (the long rows, alternating layout).
    Slab {
        /// L.
        layers: usize,
        /// M.
        grains_per_layer: usize,
        /// Row layout.
        rows: RowLayout,
    },
    /// A triangular pile.
    Pile {
        /// Layers.
        layers: usize,
        /// Grains in the top layer.
        top_grains: usize,
    },
}

/// Lattice sites: centre positions, row index (0 at the bottom) and the box width.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sites {
    /// Centres (x, z), row by row from the bottom, left to right.
    pub positions: Vec<[f64; 2]>,
    /// Row of each site.
    pub rows: Vec<usize>,
    /// Distance between the side walls.
    pub width: f64,
    /// Number of rows.
    pub row_count: usize,
}

impl Sites {
    /// Sites of `shape`.
    pub fn of(shape: Shape) -> Sites {
        let dz = 3f64.sqrt();
        let mut positions = Vec::new();
        let mut rows = Vec::new();
        match shape {
            Shape::Slab { layers, grains_per_layer: m, rows: layout } => {
                let alternate = layout == RowLayout::AlternatingMAndMMinus1;
                let top_long = m % 2 == 1;
                for r in 0..layers {
                    let z = 1.0 + r as f64 * dz;
                    let xs: Vec<f64> = if alternate {
                        let long = ((layers - 1 - r) % 2 == 0) == top_long;
                        if long {
                            (0..m).map(|k| (2 * k + 1) as f64).collect()
                        } else {
                            (0..m - 1).map(|k| (2 * k + 2) as f64).collect()
                        }
                    } else {
                        let offset = if r % 2 == 0 { 1.0 } else { 2.0 };
                        (0..m).map(|k| 2.0 * k as f64 + offset).collect()
                    };
                    for x in xs {
                        positions.push([x, z]);
                        rows.push(r);
                    }
                }
                let width = if alternate { 2.0 * m as f64 } else { 2.0 * m as f64 + 1.0 };
                Sites { positions, rows, width, row_count: layers }
            }
            Shape::Pile { layers, top_grains } => {
                let bottom = top_grains + layers - 1;
                for r in 0..layers {
                    let z = 1.0 + r as f64 * dz;
                    for k in 0..bottom - r {
                        positions.push([r as f64 + 2.0 * k as f64 + 1.0, z]);
                        rows.push(r);
                    }
                }
                Sites { positions, rows, width: 2.0 * bottom as f64, row_count: layers }
            }
        }
    }

    /// Ids (= site indices) of the top row.
    pub fn top_row(&self) -> Vec<u32> {
        let top = self.row_count - 1;
        (0..self.positions.len()).filter(|&k| self.rows[k] == top).map(|k| k as u32).collect()
    }

    /// The top-row grain whose site is nearest to `x` (the leftmost of equally near ones).
    pub fn top_grain_near(&self, x: f64) -> u32 {
        let mut best = (f64::INFINITY, 0u32);
        for id in self.top_row() {
            let d = (self.positions[id as usize][0] - x).abs();
            if d < best.0 - 1e-12 {
                best = (d, id);
            }
        }
        best.1
    }

    /// Height of the top of the lattice (top row centres + R̄).
    pub fn top(&self) -> f64 {
        1.0 + (self.row_count - 1) as f64 * 3f64.sqrt() + 1.0
    }
}

/// The resolved contact parameters of one packing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// k_N.
    pub normal_stiffness: f64,
    /// k_T/k_N.
    pub ratio: f64,
    /// μ.
    pub friction: f64,
    /// Floor μ.
    pub wall_friction: f64,
    /// Side-wall μ.
    pub side_wall_friction: f64,
    /// k_N^wall/k_N.
    pub wall_stiffness_ratio: f64,
    /// γ_N.
    pub normal_damping: f64,
    /// γ_T.
    pub tangential_damping: f64,
    /// Wall γ_N.
    pub wall_normal_damping: f64,
    /// Wall γ_T.
    pub wall_tangential_damping: f64,
}

impl Material {
    /// Resolves `m` with friction μ and ratio k_T/k_N (sweeps replace the config's values); the
    /// walls follow μ unless the config fixes their friction.
    pub fn resolve(m: &MaterialConfig, friction: f64, ratio: f64) -> Material {
        let k = m.normal_stiffness;
        let kw = m.wall_stiffness_ratio * k;
        let wall_friction = m.wall_friction.unwrap_or(friction);
        Material {
            normal_stiffness: k,
            ratio,
            friction,
            wall_friction,
            side_wall_friction: m.side_wall_friction.unwrap_or(wall_friction),
            wall_stiffness_ratio: m.wall_stiffness_ratio,
            normal_damping: m.normal_damping.unwrap_or(k.sqrt()),
            tangential_damping: m.tangential_damping.unwrap_or((ratio * k).sqrt()),
            wall_normal_damping: m.wall_normal_damping.unwrap_or(kw.sqrt()),
            wall_tangential_damping: m.wall_tangential_damping.unwrap_or((ratio * kw).sqrt()),
        }
    }

    fn law(k: f64, ratio: f64, gamma_n: f64, gamma_t: f64, friction: f64) -> ContactLaw {
        let frictional = friction > 0.0;
        ContactLaw {
            normal: NormalElastic::Hooke(Hooke { stiffness: k }),
            damping: Dashpot { coefficient: gamma_n }.into(),
            tangential: if frictional { Tangential::Linear(Linear { stiffness: ratio * k }) } else { Tangential::None },
            tangential_damping: if frictional { Coefficient { coefficient: gamma_t }.into() } else { TangentialDamping::None },
            friction,
            rolling: Rolling::None,
            twisting: Twisting::None,
        }
    }

    /// Grain–grain law.
    pub fn grain_law(&self) -> ContactLaw {
        Self::law(self.normal_stiffness, self.ratio, self.normal_damping, self.tangential_damping, self.friction)
    }

    /// Grain–wall law with friction `friction`.
    pub fn wall_law(&self, friction: f64) -> ContactLaw {
        Self::law(self.wall_stiffness_ratio * self.normal_stiffness, self.ratio, self.wall_normal_damping, self.wall_tangential_damping, friction)
    }

    /// True when no contact has a tangential force (grains and all walls frictionless).
    pub fn frictionless(&self) -> bool {
        self.friction == 0.0 && self.wall_friction == 0.0 && self.side_wall_friction == 0.0
    }
}

/// Radii of `n` grains: R̄ = 1, or uniform in [1 − δ, 1] from the sample's seed.
pub fn radii(n: usize, delta: f64, seed: u64) -> Result<Vec<f64>> {
    if delta == 0.0 {
        return Ok(vec![1.0; n]);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok(SizeDistribution::UniformRadius { max_radius: 1.0, delta }.sample(n, &mut rng)?)
}

/// Builds the engine simulation of `sites` with `radii` and `material` (gravity −ẑ, floor and
/// side walls; walls 0 = floor, 1 = left, 2 = right).
pub fn build(sites: &Sites, radii: &[f64], material: &Material, integration: &IntegrationConfig, seed: u64) -> Result<Simulation<D2>> {
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    for (p, &r) in sites.positions.iter().zip(radii) {
        grains.push(DVec2::new(p[0], p[1]), r, DENSITY, DVec2::ZERO);
    }
    let height = sites.top() + 20.0;
    let domain = Domain::new(DVec2::ZERO, DVec2::new(sites.width, height), [false; 3])
        .with_wall(Wall::axis_aligned("floor", 1, 0.0, true, material.wall_law(material.wall_friction)))
        .with_wall(Wall::axis_aligned("left", 0, 0.0, true, material.wall_law(material.side_wall_friction)))
        .with_wall(Wall::axis_aligned("right", 0, sites.width, false, material.wall_law(material.side_wall_friction)));
    let sim = SimulationBuilder::new(grains, domain, material.grain_law())
        .gravity(DVec2::new(0.0, -1.0))
        .integrator(match integration.integrator {
            IntegratorName::Beeman => Integrator::Beeman,
            IntegratorName::VelocityVerlet => Integrator::VelocityVerlet,
        })
        .dt(integration.dt)
        .safety(Safety { max_overlap_fraction: 0.3 })
        .seed(seed)
        .build()?;
    Ok(sim)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_sites_are_symmetric_with_a_centre_grain_on_top() {
        for (l, m) in [(15, 60), (25, 13), (4, 6), (5, 7)] {
            let s = Sites::of(Shape::Slab { layers: l, grains_per_layer: m, rows: RowLayout::AlternatingMAndMMinus1 });
            assert_eq!(s.width, 2.0 * m as f64);
            let axis = 0.5 * s.width;
            let centre = s.top_grain_near(axis);
            assert_eq!(s.positions[centre as usize][0], axis, "{l} × {m}: a top grain on the axis");
            // mirror symmetry: every site has its image
            for p in &s.positions {
                let img = [s.width - p[0], p[1]];
                assert!(s.positions.iter().any(|q| (q[0] - img[0]).abs() < 1e-12 && q[1] == img[1]));
                assert!(p[0] >= 1.0 && p[0] <= s.width - 1.0);
            }
            // each wall is at distance R̄ from the nearest centres
            let min_x = s.positions.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
            assert_eq!(min_x, 1.0);
        }
        let s = Sites::of(Shape::Slab { layers: 15, grains_per_layer: 60, rows: RowLayout::AlternatingMAndMMinus1 });
        assert_eq!(s.positions.len(), 8 * 59 + 7 * 60);
    }

    #[test]
    fn full_rows_slab_is_the_papers_900_grain_lattice() {
        // SPEC §7.2.1: "15 layers of 60" = 900 grains, every row 60, rows shifted by R̄, box 121 R̄
        let s = Sites::of(Shape::Slab { layers: 15, grains_per_layer: 60, rows: RowLayout::Full });
        assert_eq!((s.positions.len(), s.width), (900, 121.0));
        for r in 0..15 {
            let xs: Vec<f64> = (0..900).filter(|&k| s.rows[k] == r).map(|k| s.positions[k][0]).collect();
            assert_eq!(xs.len(), 60, "row {r}");
            // spacing 2R̄ along the row; rows shifted by R̄
            assert!(xs.windows(2).all(|w| w[1] - w[0] == 2.0));
            assert_eq!(xs[0], if r % 2 == 0 { 1.0 } else { 2.0 });
            // each row touches exactly one side wall (a centre at distance R̄), the other is 2R̄ away
            let gaps = (xs[0], s.width - xs[59]);
            assert!(gaps == (1.0, 2.0) || gaps == (2.0, 1.0), "row {r}: {gaps:?}");
        }
        // the default load: the top-row grain nearest the axis x = 60.5
        let c = s.top_grain_near(0.5 * s.width);
        assert_eq!(s.positions[c as usize], [61.0, 1.0 + 14.0 * 3f64.sqrt()]);
        assert_eq!(crate::config::SlabConfig::default().rows, RowLayout::Full, "the paper's lattice is the default");
    }

    #[test]
    fn pile_sites() {
        let s = Sites::of(Shape::Pile { layers: 11, top_grains: 1 });
        assert_eq!(s.positions.len(), 66);
        assert_eq!(s.width, 22.0);
        assert_eq!(s.top_row().len(), 1);
        assert_eq!(s.positions[s.top_row()[0] as usize][0], 11.0);
    }
}
