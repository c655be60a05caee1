//! Elastic moduli of a packing (SPEC §5.3) by imposed strain and linear relaxation, local moduli
//! by body forces and imposed lines, and continuum sound speeds.
//!
//! # Global moduli
//!
//! A homogeneous displacement gradient e (symmetric, the strain ε) is imposed on the grain centres,
//! the walls and the periodic lengths (every contact's relative displacement gains e·b, see
//! [`crate::contact`]); the grains then relax (translations and rotations, static linear problem).
//! With the total elastic energy W(q, ε) = ½ qᵀDq + qᵀLε + ½ εᵀAε,
//!
//! ```text
//! relaxed:   q(ε) = −D⁻¹ L ε,      C = (A − Lᵀ D⁻¹ L) / V
//! affine:    C_aff = A / V          (no relaxation: an upper bound, C_aff − C ⪰ 0)
//! ```
//!
//! in Voigt notation (2D: [xx, yy, xy]; 3D: [xx, yy, zz, yz, xz, xy]; shear strains are engineering
//! strains γ = 2ε_αβ), so σ = C ε and W/V = ½ εᵀ C ε. With pre-stress off, σ = C ε is exactly the
//! change of the contact stress σ_αβ = (1/V) Σ_c f_α b_β. The matrix C is the same whether strains
//! and stresses are counted positive in compression (SPEC §5.3) or in extension, since both flip.
//! In the SPEC's 2D notation (axis 1 = x, periodic; axis 2 = y, piston axis): C₁₁ = `C[0][0]`,
//! C₁₂ = `C[0][1]`, C₂₂ = `C[1][1]`, and σ₁₂ = 2C₃₃ε₁₂ gives C₃₃ = `C[2][2]`.
//!
//! **Volume V** ([`VolumeConvention`]): the periodic lengths and the distances between opposite
//! walls span the cell; `sphere2d` uses V = area × mean diameter (the 3D stress of E1), `disk` the
//! area (2D stress), `sphere` the volume. **Density** ρ* = Σ m_i / V over non-rattlers (with unit
//! grain density this is the solid fraction Φ₃* of SPEC §5.3). **Continuum speeds**:
//! c_ℓ = √(C_zzzz/ρ*), c_t = √(C_xzxz/ρ*), z the last axis (the piston axis).
//!
//! # Local moduli (walls along the last axis, held fixed)
//!
//! * **Body force** ([`LocalLoading::BodyForce`]): every non-rattler i receives the force
//!   f₀ sin(nπ y_i/L₂) · V v_i/Σv along axis α (v_i the grain volume; = (4πR_i³/(3Φ₃*)) f₀ sin(…)
//!   of SPEC §5.3), y measured from the lower wall, L₂ the wall gap. The static response stores
//!   W = ½ fᵀu, and a continuum of modulus C_α would store W = f₀² L₂² V/(4n²π²C_α)
//!   (= L₁L₂³f₀²/(4n²π²C_α) per unit thickness), hence C_α.
//! * **Imposed lines** ([`LocalLoading::ImposedLines`], n odd): on the n + 2 lines
//!   y_k = k L₂/(n+1), k = 0 … n+1, the grains whose disk the line crosses (|y_i − y_k| < R_i) get
//!   the displacement u₀ (−1)^l along α on k = 2l + 1 and 0 on even k; with `fix_transverse` their
//!   other translations are held at 0; rotations are free. A continuum stores
//!   W = (n+1)² C_α u₀² V/(2L₂²) (= (n+1)²L₁C_α u₀²/(2L₂) per unit thickness), hence C_α.
//!
//! α = x (horizontal) probes the shear modulus C₃₃, α = y (vertical) the longitudinal C₂₂.

use crate::contact::Partner;
use crate::dofs::Constraints;
use crate::dynamical::{apply_gradient, DynamicalMatrix, ZeroRows};
use crate::error::{LinearError, Result};
use crate::statics::{solve_static, StaticOptions};
use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::grains::GrainKind;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// How the cell volume V of stresses and moduli is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum VolumeConvention {
    /// `sphere2d`: area × mean diameter; `disk`: area; `sphere`: volume (default).
    #[default]
    Auto,
    /// Area (2D stresses, force per length).
    Area,
    /// Area × mean diameter ("3D pressure" of `sphere2d` packings).
    AreaTimesMeanDiameter,
    /// A given volume.
    Explicit {
        /// V.
        volume: f64,
    },
}

/// The cell of a packing: extents and the walls along the last axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// Extent along each axis: the periodic length, the gap between two opposite axis-aligned walls,
    /// or the domain extent.
    pub lengths: Vec<f64>,
    /// V of the chosen convention.
    pub volume: f64,
    /// Lower wall along the last axis (inward normal +e_z) and its coordinate.
    pub lower_wall: Option<(u32, f64)>,
    /// Upper wall along the last axis (inward normal −e_z) and its coordinate.
    pub upper_wall: Option<(u32, f64)>,
}

/// The cell of `dm`'s snapshot under `convention`.
pub fn cell<D: Dim>(dm: &DynamicalMatrix<D>, convention: VolumeConvention) -> Result<Cell> {
    let dom = dm.domain();
    let mut lengths = Vec::with_capacity(D::D);
    let mut lower_wall = None;
    let mut upper_wall = None;
    for k in 0..D::D {
        let mut lo = None;
        let mut hi = None;
        for (w, wall) in dom.walls.iter().enumerate() {
            let nk = wall.normal.get(k);
            if (nk.abs() - 1.0).abs() < 1e-12 {
                let x = wall.position.get(k);
                if nk > 0.0 {
                    lo = Some((w as u32, x));
                } else {
                    hi = Some((w as u32, x));
                }
            }
        }
        let l = match (dom.is_periodic(k), lo, hi) {
            (true, _, _) => dom.length(k),
            (false, Some((_, a)), Some((_, b))) => b - a,
            _ => dom.length(k),
        };
        if k == D::D - 1 {
            lower_wall = lo;
            upper_wall = hi;
        }
        lengths.push(l);
    }
    let product: f64 = lengths.iter().product();
    let radii = dm.radii();
    let mean_diameter = 2.0 * radii.iter().sum::<f64>() / radii.len() as f64;
    let volume = match convention {
        VolumeConvention::Auto => match dm.kind() {
            GrainKind::Sphere2d => product * mean_diameter,
            GrainKind::Disk { .. } | GrainKind::Sphere => product,
        },
        VolumeConvention::Area => product,
        VolumeConvention::AreaTimesMeanDiameter => product * mean_diameter,
        VolumeConvention::Explicit { volume } => volume,
    };
    if !(volume.is_finite() && volume > 0.0) {
        return Err(LinearError::invalid("volume", volume, "a finite volume > 0"));
    }
    Ok(Cell { lengths, volume, lower_wall, upper_wall })
}

/// Options of the moduli computations.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ModuliOptions {
    /// Volume convention (default [`VolumeConvention::Auto`]).
    pub volume: VolumeConvention,
    /// Mass density ρ* for the continuum speeds (default Σ m / V over non-rattlers).
    pub density: Option<f64>,
    /// Static solver settings.
    pub solver: StaticOptions,
}

/// Voigt stiffness matrices of a packing and derived quantities.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ElasticModuli {
    /// Relaxed stiffness C (Voigt, 3 × 3 in 2D, 6 × 6 in 3D).
    pub voigt: Vec<Vec<f64>>,
    /// Affine stiffness C_aff = A/V (no relaxation).
    pub affine: Vec<Vec<f64>>,
    /// Cell volume V.
    pub volume: f64,
    /// Density ρ* used for the speeds.
    pub density: f64,
    /// c_ℓ = √(C_zzzz/ρ*) along the last axis.
    pub longitudinal_speed: f64,
    /// c_t = √(C_xzxz/ρ*).
    pub transverse_speed: f64,
    /// Largest |C_kl − C_lk| / max |C| before symmetrization (a check of the solves).
    pub asymmetry: f64,
    /// CG iterations of each relaxation.
    pub iterations: Vec<usize>,
}

impl ElasticModuli {
    /// C₁₁ (2D: σ_xx/ε_xx).
    pub fn c11(&self) -> f64 {
        self.voigt[0][0]
    }
    /// C₁₂.
    pub fn c12(&self) -> f64 {
        self.voigt[0][1]
    }
    /// C₂₂ (2D: σ_yy/ε_yy).
    pub fn c22(&self) -> f64 {
        self.voigt[1][1]
    }
    /// C₃₃ of SPEC §5.3 (σ₁₂ = 2C₃₃ε₁₂; in 3D the xy shear, Voigt `[5][5]`).
    pub fn c33(&self) -> f64 {
        let k = self.voigt.len() - 1;
        self.voigt[k][k]
    }
}

/// Voigt basis strain `k` as a row-major d × d displacement gradient (symmetric; shear entries ½).
pub fn voigt_strain(d: usize, k: usize) -> Vec<f64> {
    let mut e = vec![0.0; d * d];
    let pairs2 = [(0, 0), (1, 1), (0, 1)];
    let pairs3 = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];
    let (a, b) = if d == 2 { pairs2[k] } else { pairs3[k] };
    if a == b {
        e[a * d + a] = 1.0;
    } else {
        e[a * d + b] = 0.5;
        e[b * d + a] = 0.5;
    }
    e
}

/// Index of the Voigt component (a, b).
fn voigt_index(d: usize, a: usize, b: usize) -> usize {
    let (a, b) = (a.min(b), a.max(b));
    if a == b {
        return a;
    }
    if d == 2 {
        2
    } else {
        match (a, b) {
            (1, 2) => 3,
            (0, 2) => 4,
            _ => 5,
        }
    }
}

/// Rattler flags computed from the linearized contacts (iterated removal, threshold 2 when any
/// contact has tangential stiffness, else d + 1), for densities and body forces.
pub(crate) fn carrying_grains<D: Dim>(dm: &DynamicalMatrix<D>) -> Vec<bool> {
    let n = dm.layout().grains;
    let frictional = dm.contacts().iter().any(|c| c.tangential_stiffness > 0.0);
    let threshold = if frictional { 2 } else { D::D + 1 };
    let mut removed = dm.removed().to_vec();
    loop {
        let mut count = vec![0usize; n];
        for c in dm.contacts().iter().filter(|c| c.normal_force > 0.0 || c.normal_stiffness > 0.0) {
            match c.j {
                Partner::Grain(j) => {
                    if !removed[c.i] && !removed[j] {
                        count[c.i] += 1;
                        count[j] += 1;
                    }
                }
                Partner::Wall(_) => {
                    if !removed[c.i] {
                        count[c.i] += 1;
                    }
                }
            }
        }
        let mut changed = false;
        for g in 0..n {
            if !removed[g] && count[g] < threshold {
                removed[g] = true;
                changed = true;
            }
        }
        if !changed {
            return removed.iter().map(|r| !r).collect();
        }
    }
}

/// Relaxed and affine Voigt stiffness of the packing of `dm` (see the module docs).
pub fn elastic_moduli<D: Dim>(dm: &DynamicalMatrix<D>, options: &ModuliOptions) -> Result<ElasticModuli> {
    let d = D::D;
    let nv = if d == 2 { 3 } else { 6 };
    let geometry = cell(dm, options.volume)?;
    let v = geometry.volume;
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep)?;
    let total = dm.dofs();
    let zero = vec![0.0; total];
    let mut loads = Vec::with_capacity(nv);
    let mut relaxed = Vec::with_capacity(nv);
    let mut iterations = Vec::with_capacity(nv);
    for k in 0..nv {
        let e = voigt_strain(d, k);
        let mut y = vec![0.0; total];
        dm.apply_with_strain(&zero, &mut y, Some(&e));
        let f: Vec<f64> = system.free_dofs().iter().map(|&r| -y[r]).collect();
        let sol = solve_static(&system, &f, &options.solver)?;
        iterations.push(sol.iterations);
        loads.push(f);
        relaxed.push(sol.displacement);
    }
    let mut affine = vec![vec![0.0; nv]; nv];
    let strains: Vec<Vec<f64>> = (0..nv).map(|k| voigt_strain(d, k)).collect();
    for c in dm.contacts() {
        let aff: Vec<D::Vector> = strains.iter().map(|e| apply_gradient::<D>(e, c.branch)).collect();
        for k in 0..nv {
            for l in 0..nv {
                let z = D::Vector::ZERO;
                let t = D::AngVector::ZERO;
                affine[k][l] += c.bilinear(z, t, z, t, aff[k], z, t, z, t, aff[l]);
            }
        }
    }
    let mut voigt = vec![vec![0.0; nv]; nv];
    for k in 0..nv {
        for l in 0..nv {
            let cross: f64 = loads[k].iter().zip(&relaxed[l]).map(|(a, b)| a * b).sum();
            voigt[k][l] = (affine[k][l] - cross) / v;
            affine[k][l] /= v;
        }
    }
    let scale = voigt.iter().flatten().fold(0.0_f64, |a, &b| a.max(b.abs()));
    let mut asym: f64 = 0.0;
    for k in 0..nv {
        for l in 0..k {
            asym = asym.max((voigt[k][l] - voigt[l][k]).abs());
            let m = 0.5 * (voigt[k][l] + voigt[l][k]);
            voigt[k][l] = m;
            voigt[l][k] = m;
        }
    }
    let density = match options.density {
        Some(rho) => rho,
        None => {
            let carrying = carrying_grains(dm);
            let p = dm.layout().per_grain();
            let m: f64 = (0..dm.layout().grains).filter(|&g| carrying[g]).map(|g| dm.mass()[g * p]).sum();
            m / v
        }
    };
    let z = d - 1;
    let c_long = voigt[voigt_index(d, z, z)][voigt_index(d, z, z)];
    let c_shear = voigt[voigt_index(d, 0, z)][voigt_index(d, 0, z)];
    Ok(ElasticModuli {
        longitudinal_speed: (c_long / density).sqrt(),
        transverse_speed: (c_shear / density).sqrt(),
        voigt,
        affine,
        volume: v,
        density,
        asymmetry: if scale > 0.0 { asym / scale } else { 0.0 },
        iterations,
    })
}

/// How a local modulus is probed (SPEC §5.3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum LocalLoading {
    /// Body force f₀ sin(nπy/L₂) along the axis (n ≥ 1).
    BodyForce {
        /// Wave number index n.
        n: usize,
    },
    /// Displacements imposed on n + 2 lines (n odd).
    ImposedLines {
        /// n (odd).
        n: usize,
        /// Hold the other translations of the line grains at 0 (default true in configs).
        fix_transverse: bool,
    },
}

/// A local modulus and the energy it came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LocalModulus {
    /// C_α.
    pub modulus: f64,
    /// Stored elastic energy W (for f₀ = 1 or u₀ = 1).
    pub energy: f64,
    /// Axis α of the loading.
    pub axis: usize,
    /// Grains that carried the load (body force: loaded grains; lines: constrained grains).
    pub grains: usize,
    /// CG iterations.
    pub iterations: usize,
}

/// Local modulus C_α along `axis` by `loading` (walls along the last axis required, held fixed).
pub fn local_modulus<D: Dim>(dm: &DynamicalMatrix<D>, axis: usize, loading: &LocalLoading, options: &ModuliOptions) -> Result<LocalModulus> {
    if axis >= D::D {
        return Err(LinearError::invalid("local_modulus.axis", axis, format!("an axis < {}", D::D)));
    }
    let geometry = cell(dm, options.volume)?;
    let (Some((_, y0)), Some((_, y1))) = (geometry.lower_wall, geometry.upper_wall) else {
        return Err(LinearError::Inconsistent("local moduli need two walls across the last axis (a lower and an upper wall)".into()));
    };
    let l2 = y1 - y0;
    let v = geometry.volume;
    let z = D::D - 1;
    let layout = *dm.layout();
    let pos = dm.positions();
    match *loading {
        LocalLoading::BodyForce { n } => {
            if n == 0 {
                return Err(LinearError::invalid("local_modulus.n", n, "an integer ≥ 1"));
            }
            let carrying = carrying_grains(dm);
            let kind = dm.kind();
            let total_measure: f64 = (0..layout.grains).filter(|&g| carrying[g]).map(|g| kind.measure(dm.radii()[g])).sum();
            let system = dm.free_system(&Constraints::new(), ZeroRows::Keep)?;
            let mut f = vec![0.0; system.dofs()];
            let mut loaded = 0;
            for g in (0..layout.grains).filter(|&g| carrying[g]) {
                let y = pos[g].get(z) - y0;
                let amp = (n as f64 * PI * y / l2).sin() * v * kind.measure(dm.radii()[g]) / total_measure;
                if let Some(k) = system.free_index(layout.translation(g, axis)) {
                    f[k] = amp;
                    loaded += 1;
                }
            }
            let sol = solve_static(&system, &f, &options.solver)?;
            let w = 0.5 * f.iter().zip(&sol.displacement).map(|(a, b)| a * b).sum::<f64>();
            Ok(LocalModulus { modulus: l2 * l2 * v / (4.0 * (n * n) as f64 * PI * PI * w), energy: w, axis, grains: loaded, iterations: sol.iterations })
        }
        LocalLoading::ImposedLines { n, fix_transverse } => {
            if n % 2 == 0 {
                return Err(LinearError::invalid("local_modulus.n", n, "an odd integer (the outer lines lie on the fixed walls)"));
            }
            let mut constraints = Constraints::new();
            let mut grains = 0;
            for g in 0..layout.grains {
                if dm.removed()[g] {
                    continue;
                }
                let y = pos[g].get(z) - y0;
                let r = dm.radii()[g];
                for k in 0..=n + 1 {
                    let yk = k as f64 * l2 / (n + 1) as f64;
                    if (y - yk).abs() < r {
                        let value = if k % 2 == 0 { 0.0 } else if (k / 2) % 2 == 0 { 1.0 } else { -1.0 };
                        for a in 0..D::D {
                            if a == axis {
                                constraints.fix(layout.translation(g, a), value);
                            } else if fix_transverse {
                                constraints.fix(layout.translation(g, a), 0.0);
                            }
                        }
                        grains += 1;
                        break;
                    }
                }
            }
            let system = dm.free_system(&constraints, ZeroRows::Keep)?;
            let sol = solve_static(&system, &vec![0.0; system.dofs()], &options.solver)?;
            let u = system.expand(&sol.displacement)?;
            let w = dm.energy(&u, None);
            let n1 = (n + 1) as f64;
            Ok(LocalModulus { modulus: 2.0 * l2 * l2 * w / (n1 * n1 * v), energy: w, axis, grains, iterations: sol.iterations })
        }
    }
}
