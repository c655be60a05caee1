//! Flat rigid walls: fixed, moving with a prescribed speed, or pistons obeying Newton's law.

use super::time_function::TimeFunction;
use crate::contact::ContactLaw;
use crate::dim::{Dim, VectorOps};
use crate::error::{require_positive, CoreError, Result};
use serde::{Deserialize, Serialize};

/// How a wall moves. All motion is along the wall's normal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WallMotion {
    /// The wall does not move.
    Fixed,
    /// Prescribed normal speed v(t); positive moves the wall into the domain (along its normal).
    Velocity {
        /// Speed as a function of time (length/time).
        speed: TimeFunction,
    },
    /// A body of mass M obeying M ẍ = F_ext(t) + (force of the grains)·n̂, with the external force
    /// F_ext(t) pushing into the domain (e.g. pressure × wall length or area).
    Piston {
        /// Mass M_w of the piston.
        mass: f64,
        /// External force F_ext(t) along the inward normal.
        force: TimeFunction,
    },
}

/// A flat rigid wall: the plane { x : (x − position)·normal = 0 }; grains live on the side the
/// normal points to. A grain of radius R whose centre is at distance h from the plane overlaps the
/// wall by ξ = R − h.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Wall<D: Dim> {
    /// Name used in outputs (e.g. "bottom", "top").
    pub name: String,
    /// Unit normal pointing into the domain.
    pub normal: D::Vector,
    /// A point of the plane (moves with the wall).
    pub position: D::Vector,
    /// Position at creation (the wall displacement is `position − origin`).
    pub origin: D::Vector,
    /// Normal speed (positive into the domain).
    pub speed: f64,
    /// Normal acceleration of the last force evaluation (pistons).
    pub accel: f64,
    /// Normal acceleration of the evaluation before (Beeman).
    pub prev_accel: f64,
    /// Prescribed motion.
    pub motion: WallMotion,
    /// Contact law between grains and this wall (its own stiffness, damping, friction).
    pub law: ContactLaw,
    /// Total force exerted by the grains on the wall at the last force evaluation.
    pub force: D::Vector,
}

impl<D: Dim> Wall<D> {
    /// A fixed wall through `position` with inward `normal` (normalized here).
    pub fn new(name: impl Into<String>, position: D::Vector, normal: D::Vector, law: ContactLaw) -> Self {
        let n = normal / normal.norm();
        Wall {
            name: name.into(),
            normal: n,
            position,
            origin: position,
            speed: 0.0,
            accel: 0.0,
            prev_accel: 0.0,
            motion: WallMotion::Fixed,
            law,
            force: D::Vector::ZERO,
        }
    }

    /// Axis-aligned wall: plane x_axis = coordinate; `inward_positive` if grains are at larger x_axis.
    pub fn axis_aligned(name: impl Into<String>, axis: usize, coordinate: f64, inward_positive: bool, law: ContactLaw) -> Self {
        let mut n = D::Vector::ZERO;
        n.set(axis, if inward_positive { 1.0 } else { -1.0 });
        let mut p = D::Vector::ZERO;
        p.set(axis, coordinate);
        Self::new(name, p, n, law)
    }

    /// Sets the motion (builder style).
    pub fn with_motion(mut self, motion: WallMotion) -> Self {
        self.motion = motion;
        self
    }

    /// Signed distance of point `x` from the plane (positive on the grains' side).
    #[inline]
    pub fn distance(&self, x: D::Vector) -> f64 {
        (x - self.position).dot(self.normal)
    }

    /// Velocity vector of the wall.
    #[inline]
    pub fn velocity(&self) -> D::Vector {
        self.normal * self.speed
    }

    /// Normal displacement since creation (positive into the domain).
    pub fn displacement(&self) -> f64 {
        (self.position - self.origin).dot(self.normal)
    }

    /// Normal force the grains exert on the wall, counted positive when they push it outwards.
    pub fn normal_load(&self) -> f64 {
        -self.force.dot(self.normal)
    }

    /// Validates normal, motion and law.
    pub fn validate(&self, index: usize) -> Result<()> {
        let field = format!("walls[{index}]");
        if !(self.normal.is_finite_vec() && (self.normal.norm() - 1.0).abs() < 1e-12) {
            return Err(CoreError::invalid(format!("{field}.normal"), format!("{:?}", self.normal), "a non-zero finite vector"));
        }
        if !self.position.is_finite_vec() {
            return Err(CoreError::invalid(format!("{field}.position"), format!("{:?}", self.position), "finite coordinates"));
        }
        match &self.motion {
            WallMotion::Fixed => {}
            WallMotion::Velocity { speed } => speed.validate(&format!("{field}.speed"))?,
            WallMotion::Piston { mass, force } => {
                require_positive(&format!("{field}.mass"), *mass)?;
                force.validate(&format!("{field}.force"))?;
            }
        }
        self.law.validate(&format!("{field}.contact"))
    }
}
