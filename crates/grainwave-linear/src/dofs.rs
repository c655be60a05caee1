//! Degrees of freedom: their numbering, and constraints (imposed displacements).
//!
//! Every grain carries `p = d + r` dofs — its translations (x, y[, z]) followed by its rotations
//! (2D: θ about ẑ; 3D: θ_x, θ_y, θ_z, small-rotation vector) — so `sphere2d` and `disk` packings
//! have 3 dofs per grain and `sphere` packings 6. The **full** dof index of component `c` of the
//! grain stored at index `g` of the snapshot is `g·p + c`. Walls are not dofs: they are fixed in the
//! linear problem, and the affine displacements imposed on them when moduli are measured enter as
//! loads (see [`crate::moduli`]).
//!
//! A [`Constraints`] value imposes displacements on chosen dofs (u_c = value). The remaining dofs
//! are **free**; [`crate::DynamicalMatrix::free_system`] builds the system on them,
//!
//! ```text
//! D_ff u_f = f_f − D_fc u_c,
//! ```
//!
//! and the dynamics M_ff ü_f = −D_ff u_f (constrained dofs held at their values — zero in pulse
//! propagation).

use crate::error::{LinearError, Result};
use grainwave_core::dim::Dim;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Numbering of the dofs of a packing of `grains` grains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DofLayout {
    /// Number of grains (the snapshot's grain count, rattlers included).
    pub grains: usize,
    /// Translational dofs per grain (the dimension d).
    pub translational: usize,
    /// Rotational dofs per grain (1 in 2D, 3 in 3D).
    pub rotational: usize,
}

impl DofLayout {
    /// Layout of `grains` grains in dimension `D`.
    pub fn of<D: Dim>(grains: usize) -> Self {
        DofLayout { grains, translational: D::D, rotational: D::ROT }
    }

    /// Dofs per grain, p = d + r.
    #[inline]
    pub fn per_grain(&self) -> usize {
        self.translational + self.rotational
    }

    /// Total number of dofs, N·p.
    #[inline]
    pub fn total(&self) -> usize {
        self.grains * self.per_grain()
    }

    /// Full index of translation along `axis` of grain `g`.
    #[inline]
    pub fn translation(&self, g: usize, axis: usize) -> usize {
        debug_assert!(axis < self.translational);
        g * self.per_grain() + axis
    }

    /// Full index of rotation about `axis` of grain `g` (2D: axis 0 is the rotation about ẑ).
    #[inline]
    pub fn rotation(&self, g: usize, axis: usize) -> usize {
        debug_assert!(axis < self.rotational);
        g * self.per_grain() + self.translational + axis
    }

    /// Grain owning full dof `dof`.
    #[inline]
    pub fn grain_of(&self, dof: usize) -> usize {
        dof / self.per_grain()
    }

    /// Component (0..p) of full dof `dof`: translations first, then rotations.
    #[inline]
    pub fn component_of(&self, dof: usize) -> usize {
        dof % self.per_grain()
    }

    /// True when `dof` is a translation.
    #[inline]
    pub fn is_translation(&self, dof: usize) -> bool {
        self.component_of(dof) < self.translational
    }
}

/// Imposed displacements on chosen dofs (full indices, see [`DofLayout`]).
///
/// A constrained dof keeps its imposed value u_c at all times; its coupling to the free dofs
/// becomes the load −D_fc u_c. Constraining a dof to zero removes it from the problem.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Constraints {
    values: BTreeMap<usize, f64>,
}

impl Constraints {
    /// No constraint.
    pub fn new() -> Self {
        Constraints::default()
    }

    /// Imposes u = `value` on full dof `dof` (replacing an earlier value).
    pub fn fix(&mut self, dof: usize, value: f64) -> &mut Self {
        self.values.insert(dof, value);
        self
    }

    /// Imposes zero displacement and rotation on every dof of grain `g`.
    pub fn fix_grain(&mut self, layout: &DofLayout, g: usize) -> &mut Self {
        for c in 0..layout.per_grain() {
            self.values.insert(g * layout.per_grain() + c, 0.0);
        }
        self
    }

    /// Imposes the translation `value` (d components) on grain `g`; rotations stay free.
    pub fn fix_translation(&mut self, layout: &DofLayout, g: usize, value: &[f64]) -> &mut Self {
        for (axis, v) in value.iter().enumerate().take(layout.translational) {
            self.values.insert(layout.translation(g, axis), *v);
        }
        self
    }

    /// Imposes zero on component `component` (0..p) of every grain, e.g. the transverse
    /// translations and rotations of a chain of grains on a line.
    pub fn fix_component_everywhere(&mut self, layout: &DofLayout, component: usize) -> &mut Self {
        for g in 0..layout.grains {
            self.values.insert(g * layout.per_grain() + component, 0.0);
        }
        self
    }

    /// Imposed value of `dof`, if constrained.
    pub fn value(&self, dof: usize) -> Option<f64> {
        self.values.get(&dof).copied()
    }

    /// True when `dof` is constrained.
    pub fn contains(&self, dof: usize) -> bool {
        self.values.contains_key(&dof)
    }

    /// Number of constrained dofs.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True when nothing is constrained.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// (dof, value) pairs in increasing dof order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.values.iter().map(|(&k, &v)| (k, v))
    }

    /// Checks that every constrained dof exists in `layout` and every value is finite.
    pub fn validate(&self, layout: &DofLayout) -> Result<()> {
        for (&dof, &v) in &self.values {
            if dof >= layout.total() {
                return Err(LinearError::invalid("constraints.dof", dof, format!("a dof index < {}", layout.total())));
            }
            if !v.is_finite() {
                return Err(LinearError::invalid(format!("constraints[{dof}]"), v, "a finite displacement"));
            }
        }
        Ok(())
    }
}
