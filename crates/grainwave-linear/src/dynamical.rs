//! The dynamical (stiffness) matrix D and the mass matrix M of a packing (SPEC §5.4).
//!
//! Around a static snapshot, every contact is replaced by its differential stiffnesses
//! ([`crate::contact`]); the packing's small motions obey
//!
//! ```text
//! M ü = −D u,      D = Σ_c ∂²E_c/∂q∂q,      M = diag(m_i, …, I_i, …)
//! ```
//!
//! with q the translations and rotations of all grains ([`crate::dofs`]). D is symmetric; it is
//! positive semi-definite unless the (optional) pre-stress term makes it indefinite.
//!
//! [`DynamicalMatrix::assemble`] builds D as a sparse row-major (CSR) faer matrix over all dofs,
//! block by block (one p × p block per pair of touching grains), and keeps the linearized contacts
//! so that D can also be applied without storing it ([`DynamicalMatrix::apply`], the matrix-free
//! operator). [`DynamicalMatrix::free_system`] restricts D and M to the free dofs of a set of
//! [`Constraints`], giving the [`LinearSystem`] that the eigensolver, the propagators and the
//! static solver work on.
//!
//! ```
//! use grainwave_core::prelude::*;
//! use grainwave_linear::prelude::*;
//! use glam::DVec2;
//!
//! // Two disks pressed together between two walls along x (Hooke law, k = 100).
//! let mut p = ContactParams::preset("hooke_cundall_strack");
//! p.normal_stiffness = Some(100.0);
//! p.friction = Some(0.0);
//! let law = p.build(Partner::Grain, "contact").unwrap();
//! let wall = p.build(Partner::Wall, "contact.wall").unwrap();
//! let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
//! g.push(DVec2::new(0.5, 0.0), 0.51, 1.0, DVec2::ZERO);
//! g.push(DVec2::new(1.5, 0.0), 0.51, 1.0, DVec2::ZERO);
//! let domain = Domain::new(DVec2::new(0.0, -2.0), DVec2::new(2.0, 2.0), [false; 3])
//!     .with_wall(Wall::axis_aligned("left", 0, 0.0, true, wall))
//!     .with_wall(Wall::axis_aligned("right", 0, 2.0, false, wall));
//! let sim = SimulationBuilder::new(g, domain, law).max_initial_overlap(0.1).build().unwrap();
//! let dm = DynamicalMatrix::assemble(&sim.snapshot(), &AssemblyOptions::default()).unwrap();
//! // x-translations: the 2 × 2 block [[2k, −k], [−k, 2k]] of a wall–grain–grain–wall chain
//! let d = dm.stiffness().to_dense();
//! assert_eq!((d[(0, 0)], d[(0, 3)], d[(3, 3)]), (200.0, -100.0, 200.0));
//! ```

use crate::contact::{LinearContact, Partner};
use crate::dofs::{Constraints, DofLayout};
use crate::error::{LinearError, Result};
use crate::rattlers::{default_min_contacts, find_rattlers};
use faer::sparse::{SparseRowMat, SparseRowMatRef, SymbolicSparseRowMat};
use faer::Mat;
use grainwave_core::contact::{Rolling, Twisting};
use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::domain::Domain;
use grainwave_core::grains::GrainKind;
use grainwave_core::snapshot::{Counterpart, Snapshot};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// What to do with rattlers (SPEC §4, §5.4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rattlers {
    /// Keep every grain (default): a rattler without contacts contributes zero modes, one per dof.
    #[default]
    Keep,
    /// Remove rattlers (found by [`crate::rattlers::find_rattlers`]) with their contacts; their
    /// dofs are not part of any [`LinearSystem`].
    Remove,
}

/// How sliding contacts (Coulomb cap reached in the snapshot) are linearized.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlidingContacts {
    /// Keep their tangential stiffness k_t (default): the response to perturbations that move the
    /// tangential force back inside the Coulomb cone, and the response of a packing whose friction
    /// is raised after preparation.
    #[default]
    Stick,
    /// Set k_t = 0 on sliding contacts (free sliding in both directions).
    Free,
}

/// Geometric terms of the contact forces (see [`crate::contact`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PreStress {
    /// Stiffnesses only (default): D = Σ_c Gᵀ K G, symmetric and positive semi-definite.
    #[default]
    None,
    /// The pre-stress term of SPEC §5.4, −(F_n/|r_ij|) on the relative transverse displacement of
    /// grain pairs: D is then the Hessian of the elastic energy (frictionless packings) — symmetric,
    /// possibly indefinite.
    Normal,
    /// `Normal` plus the first-order terms of the stored tangential forces and rolling torques
    /// (rotation with the normal, lever-arm changes): the exact Jacobian of the engine's contact
    /// forces at a frictional snapshot. Not symmetric: for direct propagation only.
    Full,
}

/// Options of [`DynamicalMatrix::assemble`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AssemblyOptions {
    /// Geometric pre-stress terms (SPEC §5.4; default [`PreStress::None`]).
    pub prestress: PreStress,
    /// Keep or remove rattlers (default keep).
    pub rattlers: Rattlers,
    /// Threshold of force-carrying contacts below which a grain is a rattler (default: 2 with
    /// friction, d + 1 without).
    pub rattler_min_contacts: Option<usize>,
    /// Linearization of sliding contacts (default [`SlidingContacts::Stick`]).
    pub sliding: SlidingContacts,
    /// Include rolling and twisting springs when the contact laws have them (default true).
    pub rolling: bool,
}

impl Default for AssemblyOptions {
    fn default() -> Self {
        AssemblyOptions { prestress: PreStress::None, rattlers: Rattlers::Keep, rattler_min_contacts: None, sliding: SlidingContacts::Stick, rolling: true }
    }
}

/// Whether [`DynamicalMatrix::free_system`] drops free dofs whose row of D is identically zero
/// (rotations of frictionless grains, dofs of grains without contacts).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ZeroRows {
    /// Keep them: each is a zero mode (ω = 0) of the eigenproblem.
    Keep,
    /// Drop them (treat them as constrained to zero): needed by static solves.
    Drop,
}

/// D and M of a packing, over all dofs, with the linearized contacts they came from.
#[derive(Clone, Debug)]
pub struct DynamicalMatrix<D: Dim> {
    layout: DofLayout,
    contacts: Vec<LinearContact<D>>,
    mass: Vec<f64>,
    removed: Vec<bool>,
    stiffness: SparseRowMat<usize, f64>,
    adjacency_start: Vec<u32>,
    adjacency: Vec<u32>,
    options: AssemblyOptions,
    kind: GrainKind,
    positions: Vec<D::Vector>,
    radii: Vec<f64>,
    domain: Domain<D>,
}

/// Reads the translation of grain `g` from a full dof vector.
#[inline]
pub(crate) fn read_u<D: Dim>(x: &[f64], layout: &DofLayout, g: usize) -> D::Vector {
    let b = g * layout.per_grain();
    D::Vector::from_slice(&x[b..b + D::D])
}

/// Reads the rotation of grain `g` from a full dof vector.
#[inline]
pub(crate) fn read_theta<D: Dim>(x: &[f64], layout: &DofLayout, g: usize) -> D::AngVector {
    let b = g * layout.per_grain() + D::D;
    D::AngVector::from_slice(&x[b..b + D::ROT])
}

impl<D: Dim> DynamicalMatrix<D> {
    /// Assembles D and M from the contact records of `snapshot`.
    ///
    /// Conventions (SPEC §2.6, [`crate::contact`]): normal n̂ from i to j (to the wall), branch
    /// from centre to centre (to the wall contact point), k_n = dF_n/dξ and k_t of the records;
    /// rolling/twisting stiffnesses from the snapshot's contact laws (grain–grain: `snapshot.law`;
    /// grain–wall: the wall's law). Walls are fixed.
    pub fn assemble(snapshot: &Snapshot<D>, options: &AssemblyOptions) -> Result<Self> {
        let n = snapshot.len();
        if n == 0 {
            return Err(LinearError::Inconsistent("the snapshot has no grains".into()));
        }
        let layout = DofLayout::of::<D>(n);
        let p = layout.per_grain();
        let mut mass = vec![0.0; layout.total()];
        for g in 0..n {
            let (m, inertia) = (snapshot.mass[g], snapshot.inertia[g]);
            if !(m.is_finite() && m > 0.0 && inertia.is_finite() && inertia > 0.0) {
                return Err(LinearError::invalid(format!("grain {} (id {}) mass/inertia", g, snapshot.id[g]), format!("{m} / {inertia}"), "finite values > 0"));
            }
            for c in 0..p {
                mass[g * p + c] = if c < D::D { m } else { inertia };
            }
        }
        let removed = match options.rattlers {
            Rattlers::Keep => vec![false; n],
            Rattlers::Remove => {
                let threshold = options.rattler_min_contacts.unwrap_or_else(|| default_min_contacts(snapshot));
                find_rattlers(snapshot, threshold)
            }
        };
        let index = snapshot.index_by_id();
        let lookup = |id: u32| -> Result<usize> {
            index
                .get(id as usize)
                .copied()
                .filter(|&k| k != usize::MAX)
                .ok_or_else(|| LinearError::Inconsistent(format!("a contact record names grain id {id}, which is not in the snapshot")))
        };
        let (roll_pair, twist_pair) = resistance(&snapshot.law.rolling, &snapshot.law.twisting, options.rolling);
        let mut contacts = Vec::with_capacity(snapshot.contacts.len());
        for c in &snapshot.contacts {
            let i = lookup(c.i)?;
            if removed[i] {
                continue;
            }
            let (j, k_r, k_tw) = match c.j {
                Counterpart::Grain(id) => {
                    let j = lookup(id)?;
                    if removed[j] {
                        continue;
                    }
                    (Partner::Grain(j), roll_pair, twist_pair)
                }
                Counterpart::Wall(w) => {
                    let wall = snapshot
                        .domain
                        .walls
                        .get(w as usize)
                        .ok_or(LinearError::UnknownWall { index: w, walls: snapshot.domain.walls.len() })?;
                    let (r, t) = resistance(&wall.law.rolling, &wall.law.twisting, options.rolling);
                    (Partner::Wall(w), r, t)
                }
            };
            let k_t = if c.sliding && options.sliding == SlidingContacts::Free { 0.0 } else { c.tangential_stiffness };
            let prestress = match j {
                Partner::Grain(_) if options.prestress != PreStress::None => c.normal_force / c.branch.norm(),
                _ => 0.0,
            };
            for (name, v) in [("normal_stiffness", c.normal_stiffness), ("tangential_stiffness", k_t), ("normal_force", c.normal_force)] {
                if !v.is_finite() {
                    return Err(LinearError::invalid(format!("contact of grain id {} {name}", c.i), v, "a finite number"));
                }
            }
            contacts.push(LinearContact {
                i,
                j,
                normal: c.normal,
                branch: c.branch,
                lever_i: c.lever_i,
                lever_j: c.lever_j,
                normal_stiffness: c.normal_stiffness,
                tangential_stiffness: k_t,
                rolling_stiffness: k_r,
                twisting_stiffness: k_tw,
                normal_force: c.normal_force,
                prestress,
                tangential_force: c.tangential_force,
                rolling_torque: if options.rolling { c.rolling_torque } else { D::AngVector::ZERO },
                full_geometry: options.prestress == PreStress::Full,
                sliding: c.sliding,
            });
        }
        let (adjacency_start, adjacency) = contact_adjacency(n, &contacts);
        let stiffness = assemble_csr::<D>(&layout, &contacts);
        Ok(DynamicalMatrix {
            layout,
            contacts,
            mass,
            removed,
            stiffness,
            adjacency_start,
            adjacency,
            options: options.clone(),
            kind: snapshot.kind,
            positions: snapshot.pos.clone(),
            radii: snapshot.radius.clone(),
            domain: snapshot.domain.clone(),
        })
    }

    /// Dof numbering.
    pub fn layout(&self) -> &DofLayout {
        &self.layout
    }

    /// Number of dofs (all grains, N·p).
    pub fn dofs(&self) -> usize {
        self.layout.total()
    }

    /// The linearized contacts (rattlers' contacts excluded when rattlers are removed).
    pub fn contacts(&self) -> &[LinearContact<D>] {
        &self.contacts
    }

    /// D over all dofs, sparse row-major.
    pub fn stiffness(&self) -> SparseRowMatRef<'_, usize, f64> {
        self.stiffness.as_ref()
    }

    /// Diagonal of M over all dofs: m_i for translations, I_i for rotations.
    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    /// Per grain: removed as a rattler.
    pub fn removed(&self) -> &[bool] {
        &self.removed
    }

    /// Options used for assembly.
    pub fn options(&self) -> &AssemblyOptions {
        &self.options
    }

    /// True unless the full (non-symmetric) linearization was assembled.
    pub fn is_symmetric(&self) -> bool {
        self.options.prestress != PreStress::Full
    }

    /// Grain kind of the snapshot.
    pub fn kind(&self) -> GrainKind {
        self.kind
    }

    /// Grain centres of the snapshot.
    pub fn positions(&self) -> &[D::Vector] {
        &self.positions
    }

    /// Grain radii of the snapshot.
    pub fn radii(&self) -> &[f64] {
        &self.radii
    }

    /// Domain (walls, periodic cell) of the snapshot.
    pub fn domain(&self) -> &Domain<D> {
        &self.domain
    }

    /// Matrix-free product y = D x over all dofs (with an optional affine displacement gradient
    /// `strain`, row-major d × d, entering every contact as e·b: then y = ∂E/∂q at q = x).
    ///
    /// Contacts are evaluated in parallel into a buffer and summed per grain in a fixed order, so
    /// the result does not depend on the number of threads.
    pub fn apply_with_strain(&self, x: &[f64], y: &mut [f64], strain: Option<&[f64]>) {
        assert_eq!(x.len(), self.dofs(), "x has the wrong length");
        assert_eq!(y.len(), self.dofs(), "y has the wrong length");
        let l = &self.layout;
        let responses: Vec<_> = self
            .contacts
            .par_iter()
            .with_min_len(256)
            .map(|c| {
                let ui = read_u::<D>(x, l, c.i);
                let ti = read_theta::<D>(x, l, c.i);
                let (uj, tj) = match c.j {
                    Partner::Grain(j) => (read_u::<D>(x, l, j), read_theta::<D>(x, l, j)),
                    Partner::Wall(_) => (D::Vector::ZERO, D::AngVector::ZERO),
                };
                let aff = strain.map_or(D::Vector::ZERO, |e| apply_gradient::<D>(e, c.branch));
                c.response(ui, ti, uj, tj, aff)
            })
            .collect();
        let p = l.per_grain();
        let (start, adj) = (&self.adjacency_start, &self.adjacency);
        y.par_chunks_mut(p).enumerate().with_min_len(256).for_each(|(g, yg)| {
            let mut f = D::Vector::ZERO;
            let mut t = D::AngVector::ZERO;
            for &e in &adj[start[g] as usize..start[g + 1] as usize] {
                let r = &responses[(e >> 1) as usize];
                if e & 1 == 0 {
                    f += r.force_i;
                    t += r.torque_i;
                } else {
                    f += r.force_j;
                    t += r.torque_j;
                }
            }
            for k in 0..D::D {
                yg[k] = -f.get(k);
            }
            for k in 0..D::ROT {
                yg[D::D + k] = -t.get(k);
            }
        });
    }

    /// Matrix-free product y = D x over all dofs.
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.apply_with_strain(x, y, None)
    }

    /// Elastic energy ½ qᵀ D q (+ affine strain `strain`), summed contact by contact.
    pub fn energy(&self, x: &[f64], strain: Option<&[f64]>) -> f64 {
        let l = &self.layout;
        self.contacts
            .iter()
            .map(|c| {
                let ui = read_u::<D>(x, l, c.i);
                let ti = read_theta::<D>(x, l, c.i);
                let (uj, tj) = match c.j {
                    Partner::Grain(j) => (read_u::<D>(x, l, j), read_theta::<D>(x, l, j)),
                    Partner::Wall(_) => (D::Vector::ZERO, D::AngVector::ZERO),
                };
                let aff = strain.map_or(D::Vector::ZERO, |e| apply_gradient::<D>(e, c.branch));
                c.energy(ui, ti, uj, tj, aff)
            })
            .sum()
    }

    /// The system on the free dofs: every dof that is not constrained, not of a removed rattler
    /// and (with [`ZeroRows::Drop`]) not a zero row of D.
    pub fn free_system(&self, constraints: &Constraints, zero_rows: ZeroRows) -> Result<LinearSystem> {
        constraints.validate(&self.layout)?;
        let total = self.dofs();
        let (row_ptr, col_idx, val) = csr_parts(&self.stiffness);
        let mut is_free = vec![true; total];
        for (dof, _) in constraints.iter() {
            is_free[dof] = false;
        }
        let p = self.layout.per_grain();
        for (g, &r) in self.removed.iter().enumerate() {
            if r {
                for c in 0..p {
                    is_free[g * p + c] = false;
                }
            }
        }
        let mut dropped = Vec::new();
        if zero_rows == ZeroRows::Drop {
            for (r, free) in is_free.iter_mut().enumerate() {
                if *free && val[row_ptr[r]..row_ptr[r + 1]].iter().all(|&v| v == 0.0) {
                    *free = false;
                    dropped.push(r);
                }
            }
        }
        let free: Vec<usize> = (0..total).filter(|&r| is_free[r]).collect();
        if free.is_empty() {
            return Err(LinearError::NoFreeDofs);
        }
        let mut full_to_free = vec![usize::MAX; total];
        for (k, &r) in free.iter().enumerate() {
            full_to_free[r] = k;
        }
        let mut sub_ptr = Vec::with_capacity(free.len() + 1);
        let mut sub_col = Vec::new();
        let mut sub_val = Vec::new();
        sub_ptr.push(0usize);
        for &r in &free {
            for e in row_ptr[r]..row_ptr[r + 1] {
                let c = full_to_free[col_idx[e]];
                if c != usize::MAX {
                    sub_col.push(c);
                    sub_val.push(val[e]);
                }
            }
            sub_ptr.push(sub_col.len());
        }
        let nf = free.len();
        let stiffness = SparseRowMat::new(SymbolicSparseRowMat::new_checked(nf, nf, sub_ptr, None, sub_col), sub_val);
        let blocks = BlockRows::from_csr(&stiffness, &free, p);
        // load of the imposed displacements: −D_fc u_c
        let mut uc = vec![0.0; total];
        let mut any = false;
        for (dof, v) in constraints.iter() {
            uc[dof] = v;
            any |= v != 0.0;
        }
        let constraint_load = if any {
            let mut y = vec![0.0; total];
            csr_matvec(row_ptr, col_idx, val, &uc, &mut y);
            free.iter().map(|&r| -y[r]).collect()
        } else {
            vec![0.0; nf]
        };
        Ok(LinearSystem {
            layout: self.layout,
            mass: free.iter().map(|&r| self.mass[r]).collect(),
            free,
            full_to_free,
            stiffness,
            constraint_load,
            imposed: uc,
            dropped,
            symmetric: self.is_symmetric(),
            blocks,
        })
    }
}

/// e·b for a row-major d × d gradient `e`.
#[inline]
pub(crate) fn apply_gradient<D: Dim>(e: &[f64], b: D::Vector) -> D::Vector {
    let mut out = D::Vector::ZERO;
    for a in 0..D::D {
        let mut s = 0.0;
        for k in 0..D::D {
            s += e[a * D::D + k] * b.get(k);
        }
        out.set(a, s);
    }
    out
}

fn resistance(rolling: &Rolling, twisting: &Twisting, include: bool) -> (f64, f64) {
    if !include {
        return (0.0, 0.0);
    }
    let r = match rolling {
        Rolling::None => 0.0,
        Rolling::SpringDashpot(l) => l.stiffness,
    };
    let t = match twisting {
        Twisting::None => 0.0,
        Twisting::SpringDashpot(l) => l.stiffness,
    };
    (r, t)
}

/// Per grain, the contacts touching it (entry = 2·contact + side, side 1 for j), in contact order.
pub(crate) fn contact_adjacency<D: Dim>(n: usize, contacts: &[LinearContact<D>]) -> (Vec<u32>, Vec<u32>) {
    let mut count = vec![0u32; n + 1];
    for c in contacts {
        count[c.i + 1] += 1;
        if let Partner::Grain(j) = c.j {
            count[j + 1] += 1;
        }
    }
    for g in 0..n {
        count[g + 1] += count[g];
    }
    let mut fill = count.clone();
    let mut entries = vec![0u32; count[n] as usize];
    for (k, c) in contacts.iter().enumerate() {
        entries[fill[c.i] as usize] = (2 * k) as u32;
        fill[c.i] += 1;
        if let Partner::Grain(j) = c.j {
            entries[fill[j] as usize] = (2 * k + 1) as u32;
            fill[j] += 1;
        }
    }
    (count, entries)
}

/// The 2p × 2p stiffness block of one contact (row-major, dofs of i then of j), computed by
/// applying the contact's response to unit displacements so that assembly and the matrix-free
/// operator share one formula.
pub(crate) fn contact_block<D: Dim>(c: &LinearContact<D>) -> Vec<f64> {
    let p = D::D + D::ROT;
    let m = 2 * p;
    let mut block = vec![0.0; m * m];
    for col in 0..m {
        let mut unit = vec![0.0; m];
        unit[col] = 1.0;
        let ui = D::Vector::from_slice(&unit[0..D::D]);
        let ti = D::AngVector::from_slice(&unit[D::D..p]);
        let uj = D::Vector::from_slice(&unit[p..p + D::D]);
        let tj = D::AngVector::from_slice(&unit[p + D::D..m]);
        let r = c.response(ui, ti, uj, tj, D::Vector::ZERO);
        let mut out = [0.0; 12];
        for k in 0..D::D {
            out[k] = -r.force_i.get(k);
            out[p + k] = -r.force_j.get(k);
        }
        for k in 0..D::ROT {
            out[D::D + k] = -r.torque_i.get(k);
            out[p + D::D + k] = -r.torque_j.get(k);
        }
        for row in 0..m {
            block[row * m + col] = out[row];
        }
    }
    block
}

/// Assembles D over all dofs as CSR: one dense p × p block per (grain, grain) pair that shares a
/// contact, plus the diagonal blocks. Blocks are computed in parallel and summed in contact order.
fn assemble_csr<D: Dim>(layout: &DofLayout, contacts: &[LinearContact<D>]) -> SparseRowMat<usize, f64> {
    let n = layout.grains;
    let p = layout.per_grain();
    let mut neighbours: Vec<Vec<usize>> = (0..n).map(|g| vec![g]).collect();
    for c in contacts {
        if let Partner::Grain(j) = c.j {
            neighbours[c.i].push(j);
            neighbours[j].push(c.i);
        }
    }
    for nb in neighbours.iter_mut() {
        nb.sort_unstable();
        nb.dedup();
    }
    let mut block_start = vec![0usize; n + 1];
    for g in 0..n {
        block_start[g + 1] = block_start[g] + neighbours[g].len();
    }
    let pp = p * p;
    let mut blocks = vec![0.0; block_start[n] * pp];
    let locals: Vec<Vec<f64>> = contacts.par_iter().with_min_len(256).map(contact_block::<D>).collect();
    let slot = |a: usize, b: usize| -> usize { block_start[a] + neighbours[a].binary_search(&b).expect("neighbour present") };
    let m = 2 * p;
    for (c, local) in contacts.iter().zip(&locals) {
        let sides: &[(usize, usize)] = match c.j {
            Partner::Grain(j) => &[(0, c.i), (1, j)],
            Partner::Wall(_) => &[(0, c.i)],
        };
        for &(sa, a) in sides {
            for &(sb, b) in sides {
                let s = slot(a, b) * pp;
                for r in 0..p {
                    for q in 0..p {
                        blocks[s + r * p + q] += local[(sa * p + r) * m + sb * p + q];
                    }
                }
            }
        }
    }
    // expand blocks to scalar rows
    let total = layout.total();
    let mut row_ptr = Vec::with_capacity(total + 1);
    row_ptr.push(0usize);
    let nnz: usize = (0..n).map(|g| neighbours[g].len() * p * p).sum();
    let mut col_idx = Vec::with_capacity(nnz);
    let mut val = Vec::with_capacity(nnz);
    for g in 0..n {
        for r in 0..p {
            for (k, &h) in neighbours[g].iter().enumerate() {
                let s = (block_start[g] + k) * pp;
                for q in 0..p {
                    col_idx.push(h * p + q);
                    val.push(blocks[s + r * p + q]);
                }
            }
            row_ptr.push(col_idx.len());
        }
    }
    SparseRowMat::new(SymbolicSparseRowMat::new_checked(total, total, row_ptr, None, col_idx), val)
}

/// Row pointers, column indices and values of a CSR matrix.
pub(crate) fn csr_parts(m: &SparseRowMat<usize, f64>) -> (&[usize], &[usize], &[f64]) {
    let s = m.symbolic();
    (s.row_ptr(), s.col_idx(), m.val())
}

/// y = A x for a CSR matrix, rows in parallel (each row summed in order: deterministic).
pub(crate) fn csr_matvec(row_ptr: &[usize], col_idx: &[usize], val: &[f64], x: &[f64], y: &mut [f64]) {
    y.par_iter_mut().enumerate().with_min_len(512).for_each(|(r, yr)| {
        let mut s = 0.0;
        for e in row_ptr[r]..row_ptr[r + 1] {
            s += val[e] * x[col_idx[e]];
        }
        *yr = s;
    });
}

/// D and M restricted to the free dofs, with the load of the imposed displacements.
///
/// ```text
/// D_ff u_f = f_f + (−D_fc u_c),       M_ff ü_f = −D_ff u_f
/// ```
#[derive(Clone, Debug)]
pub struct LinearSystem {
    layout: DofLayout,
    free: Vec<usize>,
    full_to_free: Vec<usize>,
    stiffness: SparseRowMat<usize, f64>,
    mass: Vec<f64>,
    constraint_load: Vec<f64>,
    imposed: Vec<f64>,
    dropped: Vec<usize>,
    symmetric: bool,
    blocks: Option<BlockRows>,
}

/// D_ff stored by p × p grain blocks with 32-bit block-column indices: the same matrix as the CSR,
/// kept alongside it when the free dofs are whole grains (the usual case) because its product
/// reads about half the memory (one index per block instead of one per entry).
#[derive(Clone, Debug)]
struct BlockRows {
    p: usize,
    row_ptr: Vec<u32>,
    col: Vec<u32>,
    val: Vec<f64>,
}

impl BlockRows {
    /// Block form of `m` if every grain is either wholly free or wholly absent and every scalar
    /// row of a block row has the same, block-aligned column pattern.
    fn from_csr(m: &SparseRowMat<usize, f64>, free: &[usize], p: usize) -> Option<BlockRows> {
        let n = free.len();
        if n % p != 0 || n / p > u32::MAX as usize {
            return None;
        }
        for (k, &f) in free.iter().enumerate() {
            if f % p != k % p || (k % p != 0 && free[k - 1] + 1 != f) {
                return None;
            }
        }
        let (rp, ci, v) = csr_parts(m);
        let nb = n / p;
        let mut row_ptr = Vec::with_capacity(nb + 1);
        row_ptr.push(0u32);
        let mut col = Vec::new();
        let mut val = Vec::new();
        for b in 0..nb {
            let first = b * p;
            let len = rp[first + 1] - rp[first];
            if len % p != 0 {
                return None;
            }
            for a in 0..p {
                let r = first + a;
                if rp[r + 1] - rp[r] != len || ci[rp[r]..rp[r + 1]] != ci[rp[first]..rp[first + 1]] {
                    return None;
                }
            }
            for k in 0..len / p {
                let c0 = ci[rp[first] + k * p];
                if c0 % p != 0 || (0..p).any(|q| ci[rp[first] + k * p + q] != c0 + q) {
                    return None;
                }
                col.push((c0 / p) as u32);
                for a in 0..p {
                    let e = rp[first + a] + k * p;
                    val.extend_from_slice(&v[e..e + p]);
                }
            }
            if col.len() > u32::MAX as usize {
                return None;
            }
            row_ptr.push(col.len() as u32);
        }
        Some(BlockRows { p, row_ptr, col, val })
    }

    /// y = A x, block rows in parallel (each summed in order: deterministic).
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        match self.p {
            3 => self.apply_fixed::<3>(x, y),
            6 => self.apply_fixed::<6>(x, y),
            _ => self.apply_generic(x, y),
        }
    }

    fn apply_fixed<const P: usize>(&self, x: &[f64], y: &mut [f64]) {
        let (rp, col, val) = (&self.row_ptr, &self.col, &self.val);
        y.par_chunks_mut(P).enumerate().with_min_len(256).for_each(|(b, yb)| {
            let mut acc = [0.0; P];
            for k in rp[b] as usize..rp[b + 1] as usize {
                let xc = &x[col[k] as usize * P..col[k] as usize * P + P];
                let blk = &val[k * P * P..(k + 1) * P * P];
                for a in 0..P {
                    let mut s = 0.0;
                    for q in 0..P {
                        s += blk[a * P + q] * xc[q];
                    }
                    acc[a] += s;
                }
            }
            yb.copy_from_slice(&acc);
        });
    }

    fn apply_generic(&self, x: &[f64], y: &mut [f64]) {
        let p = self.p;
        let (rp, col, val) = (&self.row_ptr, &self.col, &self.val);
        y.par_chunks_mut(p).enumerate().with_min_len(256).for_each(|(b, yb)| {
            yb.iter_mut().for_each(|v| *v = 0.0);
            for k in rp[b] as usize..rp[b + 1] as usize {
                let c = col[k] as usize * p;
                for a in 0..p {
                    let mut s = 0.0;
                    for q in 0..p {
                        s += val[(k * p + a) * p + q] * x[c + q];
                    }
                    yb[a] += s;
                }
            }
        });
    }
}

impl LinearSystem {
    /// True unless D is the full (non-symmetric) linearization ([`PreStress::Full`]).
    pub fn is_symmetric(&self) -> bool {
        self.symmetric
    }

    /// Error unless D is symmetric (modes, static solves and moduli need it).
    pub(crate) fn require_symmetric(&self, what: &str) -> Result<()> {
        if self.symmetric {
            Ok(())
        } else {
            Err(LinearError::NotSymmetric { what: what.into() })
        }
    }

    /// Number of free dofs.
    pub fn dofs(&self) -> usize {
        self.free.len()
    }

    /// Dof numbering of the full problem.
    pub fn layout(&self) -> &DofLayout {
        &self.layout
    }

    /// D_ff, sparse row-major.
    pub fn stiffness(&self) -> SparseRowMatRef<'_, usize, f64> {
        self.stiffness.as_ref()
    }

    /// Diagonal of M_ff.
    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    /// Full index of every free dof (increasing).
    pub fn free_dofs(&self) -> &[usize] {
        &self.free
    }

    /// Free index of full dof `dof`, if free.
    pub fn free_index(&self, dof: usize) -> Option<usize> {
        self.full_to_free.get(dof).copied().filter(|&k| k != usize::MAX)
    }

    /// Dofs that were free but dropped as zero rows of D.
    pub fn dropped_dofs(&self) -> &[usize] {
        &self.dropped
    }

    /// −D_fc u_c: the load that the imposed displacements exert on the free dofs.
    pub fn constraint_load(&self) -> &[f64] {
        &self.constraint_load
    }

    /// y = D_ff x (parallel over rows, deterministic; by grain blocks when the free dofs are whole
    /// grains, otherwise by the scalar CSR).
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.dofs(), "x has the wrong length");
        assert_eq!(y.len(), self.dofs(), "y has the wrong length");
        match &self.blocks {
            Some(b) => b.apply(x, y),
            None => {
                let (rp, ci, v) = csr_parts(&self.stiffness);
                csr_matvec(rp, ci, v, x, y);
            }
        }
    }

    /// True when products use the grain-block storage (free dofs are whole grains).
    pub fn has_block_storage(&self) -> bool {
        self.blocks.is_some()
    }

    /// Full dof vector from free values: imposed values on constrained dofs, 0 on removed ones.
    pub fn expand(&self, free_values: &[f64]) -> Result<Vec<f64>> {
        LinearError::check_len("free_values", self.dofs(), free_values.len())?;
        let mut out = self.imposed.clone();
        for (k, &r) in self.free.iter().enumerate() {
            out[r] = free_values[k];
        }
        Ok(out)
    }

    /// Free entries of a full dof vector.
    pub fn restrict(&self, full: &[f64]) -> Result<Vec<f64>> {
        LinearError::check_len("full", self.layout.total(), full.len())?;
        Ok(self.free.iter().map(|&r| full[r]).collect())
    }

    /// D_ff as a dense matrix.
    pub fn to_dense(&self) -> Mat<f64> {
        self.stiffness.to_dense()
    }

    /// Diagonal of D_ff.
    pub fn diagonal(&self) -> Vec<f64> {
        let (rp, ci, v) = csr_parts(&self.stiffness);
        (0..self.dofs())
            .map(|r| (rp[r]..rp[r + 1]).find(|&e| ci[e] == r).map_or(0.0, |e| v[e]))
            .collect()
    }

    /// Gershgorin bound on the largest eigenvalue ω²_max of M⁻¹D:
    /// max_r Σ_c |D_rc| / √(m_r m_c) ≥ λ_max(M^{-1/2} D M^{-1/2}).
    pub fn gershgorin_bound(&self) -> f64 {
        let (rp, ci, v) = csr_parts(&self.stiffness);
        let m = &self.mass;
        (0..self.dofs())
            .into_par_iter()
            .with_min_len(1024)
            .map(|r| (rp[r]..rp[r + 1]).map(|e| v[e].abs() / (m[r] * m[ci[e]]).sqrt()).sum::<f64>())
            .reduce(|| 0.0, f64::max)
    }
}

/// Applies `f` to every column of `rhs`, writing `out` (faer operator glue).
fn apply_columns(out: faer::MatMut<'_, f64>, rhs: faer::MatRef<'_, f64>, f: impl Fn(&[f64], &mut [f64])) {
    let mut out = out;
    let mut x = vec![0.0; rhs.nrows()];
    let mut y = vec![0.0; out.nrows()];
    for j in 0..rhs.ncols() {
        for i in 0..rhs.nrows() {
            x[i] = rhs[(i, j)];
        }
        f(&x, &mut y);
        for i in 0..out.nrows() {
            out[(i, j)] = y[i];
        }
    }
}

impl faer::matrix_free::LinOp<f64> for LinearSystem {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: faer::Par) -> faer::dyn_stack::StackReq {
        faer::dyn_stack::StackReq::EMPTY
    }
    fn nrows(&self) -> usize {
        self.dofs()
    }
    fn ncols(&self) -> usize {
        self.dofs()
    }
    fn apply(&self, out: faer::MatMut<'_, f64>, rhs: faer::MatRef<'_, f64>, _par: faer::Par, _stack: &mut faer::dyn_stack::MemStack) {
        apply_columns(out, rhs, |x, y| LinearSystem::apply(self, x, y));
    }
    fn conj_apply(&self, out: faer::MatMut<'_, f64>, rhs: faer::MatRef<'_, f64>, _par: faer::Par, _stack: &mut faer::dyn_stack::MemStack) {
        apply_columns(out, rhs, |x, y| LinearSystem::apply(self, x, y));
    }
}

impl<D: Dim> faer::matrix_free::LinOp<f64> for DynamicalMatrix<D> {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: faer::Par) -> faer::dyn_stack::StackReq {
        faer::dyn_stack::StackReq::EMPTY
    }
    fn nrows(&self) -> usize {
        self.dofs()
    }
    fn ncols(&self) -> usize {
        self.dofs()
    }
    fn apply(&self, out: faer::MatMut<'_, f64>, rhs: faer::MatRef<'_, f64>, _par: faer::Par, _stack: &mut faer::dyn_stack::MemStack) {
        apply_columns(out, rhs, |x, y| DynamicalMatrix::apply(self, x, y));
    }
    fn conj_apply(&self, out: faer::MatMut<'_, f64>, rhs: faer::MatRef<'_, f64>, _par: faer::Par, _stack: &mut faer::dyn_stack::MemStack) {
        apply_columns(out, rhs, |x, y| DynamicalMatrix::apply(self, x, y));
    }
}
