//! A catheter as a 3-D corotational beam (thesis chapter 5): Euler-Bernoulli elements with
//! 6 DOF per node, a quasi-static Newton solve, and compliance W = H K⁻¹ Hᵀ over rows that
//! mix translations and rotations (5.1-5.3).
//!
//! Each node carries a position and an orientation (`UnitQuaternion`, node frame to world;
//! the node frame's x axis runs along the rod). Newton increments are translations and
//! spatial spins, applied to the orientations multiplicatively by the exponential map. The
//! element (`element.rs`) is the corotational one of Crisfield: a rigid frame from the chord
//! and the mean of the ends' transverse axes, local deformations (stretch, twist, two
//! bending rotations per end) against that frame, and the linear Euler-Bernoulli stiffness
//! on them. The tangent is the consistent one: the material part Bᵀ K_l B analytic, the
//! geometric part by central differences of the analytic B; it is symmetrised before faer's
//! sparse Cholesky (the spin parametrisation makes it slightly unsymmetric off
//! equilibrium, so Newton is then quasi-quadratic). Loads from cables ([`cable`]) follow
//! the rod; their load stiffness is left out of the tangent (Newton converges linearly
//! under them, to the same equilibrium).
//!
//! Node 0 is clamped (the base); its pose may be prescribed relative to rest
//! ([`BeamLoads::base_from_rest`], [`BeamModel::insertion`]).
//!
//! ```
//! use softsense::fem::beam::{BeamLoads, BeamMaterial, BeamModel, BeamParams, BeamSection, NodeLoad};
//! # fn main() -> Result<(), softsense::fem::FemError> {
//! let section = BeamSection::circular(1.0e-3)?;
//! let model = BeamModel::straight(0.2, 4, section, BeamMaterial::new(1.4e9, 0.35)?)?;
//! let mut loads = BeamLoads::default();
//! loads.nodes.push(NodeLoad::force(4, [0.0, -1.0e-3, 0.0]));
//! let sol = model.solve_static(&model.rest_state(), &loads, &BeamParams::default())?;
//! assert!(sol.status.is_converged());
//! assert!(sol.state.nodes_in_world[4].y < 0.0);
//! # Ok(()) }
//! ```

pub mod cable;
mod element;
mod solve;

pub use cable::BeamCable;
pub use solve::{BeamLinearisation, BeamRow};

use super::{FemError, FemResult};
use crate::math::{Iso3, Vec3};
use element::ElementRest;
use nalgebra::UnitQuaternion;

/// Elastic constants of the rod's material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamMaterial {
    /// Young's modulus E (Pa).
    pub young_modulus: f64,
    /// Shear modulus G (Pa); E / (2(1 + ν)) when made from ν.
    pub shear_modulus: f64,
}

impl BeamMaterial {
    /// From E (Pa) and Poisson's ratio ν (−1 < ν < 0.5).
    pub fn new(young_modulus: f64, poisson: f64) -> FemResult<Self> {
        if !(poisson > -1.0 && poisson < 0.5) {
            return Err(FemError::Material(format!(
                "Poisson's ratio {poisson} outside (-1, 0.5)"
            )));
        }
        Self::with_shear_modulus(young_modulus, young_modulus / (2.0 * (1.0 + poisson)))
    }

    /// From E and G (Pa, both positive).
    pub fn with_shear_modulus(young_modulus: f64, shear_modulus: f64) -> FemResult<Self> {
        let positive = young_modulus > 0.0 && shear_modulus > 0.0;
        if !(positive && young_modulus.is_finite() && shear_modulus.is_finite()) {
            return Err(FemError::Material(format!(
                "E = {young_modulus} Pa and G = {shear_modulus} Pa must be positive"
            )));
        }
        Ok(Self {
            young_modulus,
            shear_modulus,
        })
    }
}

/// A circular or annular (tube) cross-section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamSection {
    /// Outer radius (m).
    pub outer_radius: f64,
    /// Inner radius (m); 0 for a solid rod.
    pub inner_radius: f64,
}

impl BeamSection {
    /// A solid circle of radius `radius` (m).
    pub fn circular(radius: f64) -> FemResult<Self> {
        Self::annular(radius, 0.0)
    }

    /// A tube, `0 ≤ inner < outer` (m).
    pub fn annular(outer_radius: f64, inner_radius: f64) -> FemResult<Self> {
        if !(outer_radius > 0.0 && inner_radius >= 0.0 && inner_radius < outer_radius) {
            return Err(FemError::Model(format!(
                "section radii outer {outer_radius} m, inner {inner_radius} m: need 0 <= inner < outer"
            )));
        }
        Ok(Self {
            outer_radius,
            inner_radius,
        })
    }

    /// Area A = π (r_o² − r_i²) (m²).
    pub fn area(&self) -> f64 {
        std::f64::consts::PI * (self.outer_radius.powi(2) - self.inner_radius.powi(2))
    }

    /// Second moment of area about a diameter, I = π (r_o⁴ − r_i⁴) / 4 (m⁴).
    pub fn second_moment(&self) -> f64 {
        std::f64::consts::FRAC_PI_4 * (self.outer_radius.powi(4) - self.inner_radius.powi(4))
    }

    /// Polar moment J = 2 I (m⁴; exact torsion constant of circles and tubes).
    pub fn polar_moment(&self) -> f64 {
        2.0 * self.second_moment()
    }
}

/// The section's rigidities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamStiffness {
    /// EA (N).
    pub axial: f64,
    /// EI (N m²), the same about both transverse axes.
    pub bending: f64,
    /// GJ (N m²).
    pub torsional: f64,
}

/// A configuration: every node's position and orientation.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamState {
    /// Node positions (m, world frame).
    pub nodes_in_world: Vec<Vec3>,
    /// Node orientations (node frame to world; the node frame's x runs along the rod).
    pub world_from_node: Vec<UnitQuaternion<f64>>,
}

/// A force and a moment at a node (world frame, dead loads).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeLoad {
    /// The node.
    pub node: usize,
    /// Force (N, world frame).
    pub force: Vec3,
    /// Moment (N m, world frame).
    pub moment: Vec3,
}

impl NodeLoad {
    /// A force alone (N, world frame).
    pub fn force(node: usize, force: [f64; 3]) -> Self {
        Self {
            node,
            force: force.into(),
            moment: Vec3::zeros(),
        }
    }

    /// A moment alone (N m, world frame).
    pub fn moment(node: usize, moment: [f64; 3]) -> Self {
        Self {
            node,
            force: Vec3::zeros(),
            moment: moment.into(),
        }
    }
}

/// A one-sided spring on a node's position along one direction: the force
/// k max(0, nᵀ(anchor − x)) n, a push only. A contact's wall as Newton sees it: under
/// contact pushes held as dead loads, a compressed rod can jump to a far equilibrium that
/// the wall would forbid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeSpring {
    /// The node.
    pub node: usize,
    /// Unit direction n of the spring (world frame).
    pub direction: Vec3,
    /// Where the spring is relaxed (m, world frame); only its component along n matters.
    pub anchor: Vec3,
    /// Stiffness k (N/m, ≥ 0).
    pub stiffness: f64,
}

impl NodeSpring {
    /// How far the node at `x` is pressed into the spring (m, ≥ 0).
    pub fn depth(&self, x: &Vec3) -> f64 {
        self.direction.dot(&(self.anchor - x)).max(0.0)
    }

    /// The spring's force on the node at `x` (N, world frame).
    pub fn force(&self, x: &Vec3) -> Vec3 {
        self.direction * (self.stiffness * self.depth(x))
    }
}

/// What acts on the rod in one static solve.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamLoads {
    /// Point loads at nodes (world frame, fixed in direction).
    pub nodes: Vec<NodeLoad>,
    /// Springs on node positions, in Newton's residual and tangent (not in
    /// [`BeamModel::linearise_loaded`]'s compliance).
    pub springs: Vec<NodeSpring>,
    /// Cables and their tensions (N, ≥ 0 pulls); their loads follow the rod.
    pub cables: Vec<(BeamCable, f64)>,
    /// Pose of the clamped nodes relative to rest (the base); identity by default.
    pub base_from_rest: Iso3,
}

impl Default for BeamLoads {
    fn default() -> Self {
        Self {
            nodes: Vec::new(),
            springs: Vec::new(),
            cables: Vec::new(),
            base_from_rest: Iso3::identity(),
        }
    }
}

/// Newton's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamParams {
    /// Load increments, each solved to convergence (large rotations want several); 1.
    pub load_steps: usize,
    /// Newton iterations per load step at most; 50.
    pub max_iterations: usize,
    /// Convergence: the largest Newton step, nodal translation over the rod's length and
    /// nodal rotation (rad); 1e-10.
    pub tolerance: f64,
    /// Largest nodal rotation increment of one Newton step (rad; the step is scaled
    /// down to it); 0.5.
    pub max_rotation_step: f64,
}

impl Default for BeamParams {
    fn default() -> Self {
        Self {
            load_steps: 1,
            max_iterations: 50,
            tolerance: 1e-10,
            max_rotation_step: 0.5,
        }
    }
}

/// How a static solve ended.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum BeamStatus {
    /// The residual met the tolerance.
    Converged,
    /// The iteration limit came first.
    MaxIterations,
    /// The tangent was not positive definite (buckling or a bad start).
    NotPositiveDefinite,
}

impl BeamStatus {
    /// Whether the solve converged.
    pub fn is_converged(&self) -> bool {
        matches!(self, BeamStatus::Converged)
    }
}

/// A static solve's outcome.
#[derive(Debug, Clone)]
pub struct BeamSolution {
    /// The final configuration (the equilibrium when converged).
    pub state: BeamState,
    /// How it ended.
    pub status: BeamStatus,
    /// Newton iterations over all load steps.
    pub iterations: usize,
    /// Norm of the last residual over the free DOFs (N and N m mixed).
    pub residual: f64,
}

/// A rod of two-node corotational elements along a polyline, node 0 clamped.
#[derive(Debug, Clone)]
pub struct BeamModel {
    rest: BeamState,
    elements: Vec<ElementRest>,
    stiffness: BeamStiffness,
    /// Clamped nodes; `[0]` (the base) by default.
    pub clamped: Vec<usize>,
}

impl BeamModel {
    /// A rod through `nodes_in_world` (N+1 points, m), N elements, node 0 clamped. The
    /// first element's transverse y axis is the world axis least aligned with it, made
    /// normal; later elements carry their frame by the smallest rotation between chords.
    pub fn new(
        nodes_in_world: Vec<[f64; 3]>,
        section: BeamSection,
        material: BeamMaterial,
    ) -> FemResult<Self> {
        let x: Vec<Vec3> = nodes_in_world.iter().map(|&p| p.into()).collect();
        if x.len() < 2 || x.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(FemError::Model(
                "a beam needs at least 2 finite nodes".into(),
            ));
        }
        let mut frames: Vec<UnitQuaternion<f64>> = Vec::with_capacity(x.len() - 1);
        for (e, w) in x.windows(2).enumerate() {
            let chord = w[1] - w[0];
            if !(chord.norm() > 1e-12) {
                return Err(FemError::Model(format!("beam element {e} has zero length")));
            }
            let frame = match frames.last() {
                None => first_frame(&chord.normalize()),
                Some(prev) => {
                    let turn = UnitQuaternion::rotation_between(&(prev * Vec3::x()), &chord)
                        .ok_or_else(|| {
                            FemError::Model(format!("beam element {e} turns back on itself"))
                        })?;
                    turn * prev
                }
            };
            frames.push(frame);
        }
        let mut world_from_node = frames.clone();
        world_from_node.push(*frames.last().expect("at least one element"));
        let elements = frames
            .iter()
            .enumerate()
            .map(|(e, f)| ElementRest {
                length: (x[e + 1] - x[e]).norm(),
                world_from_element: *f,
                node_from_element: [
                    world_from_node[e].inverse() * f,
                    world_from_node[e + 1].inverse() * f,
                ],
            })
            .collect();
        let stiffness = BeamStiffness {
            axial: material.young_modulus * section.area(),
            bending: material.young_modulus * section.second_moment(),
            torsional: material.shear_modulus * section.polar_moment(),
        };
        Ok(Self {
            rest: BeamState {
                nodes_in_world: x,
                world_from_node,
            },
            elements,
            stiffness,
            clamped: vec![0],
        })
    }

    /// A straight rod from the origin along +x, `length` (m) in `elements` equal parts.
    pub fn straight(
        length: f64,
        elements: usize,
        section: BeamSection,
        material: BeamMaterial,
    ) -> FemResult<Self> {
        let n = elements.max(1);
        let nodes = (0..=n)
            .map(|i| [length * i as f64 / n as f64, 0.0, 0.0])
            .collect();
        Self::new(nodes, section, material)
    }

    /// Number of nodes (N + 1).
    pub fn node_count(&self) -> usize {
        self.rest.nodes_in_world.len()
    }

    /// The section's rigidities EA, EI, GJ.
    pub fn stiffness(&self) -> BeamStiffness {
        self.stiffness
    }

    /// Rest length along the polyline (m).
    pub fn length(&self) -> f64 {
        self.elements.iter().map(|e| e.length).sum()
    }

    /// The rest configuration.
    pub fn rest_state(&self) -> BeamState {
        self.rest.clone()
    }

    /// The base pose of an insertion: the base moved by `distance` (m) along its own axis
    /// (node 0's x axis at rest).
    pub fn insertion(&self, distance: f64) -> Iso3 {
        let axis = self.rest.world_from_node[0] * Vec3::x();
        Iso3::translation(axis.x * distance, axis.y * distance, axis.z * distance)
    }

    /// Element `e`'s rest frame (element frame to world; x along the chord).
    pub fn rest_element_frame(&self, e: usize) -> UnitQuaternion<f64> {
        self.elements[e].world_from_element
    }
}

/// A frame with x along `axis` and y the world y made normal to it (world z for an axis
/// near y), so a straight rod along +x has the world's axes as node frames.
fn first_frame(axis: &Vec3) -> UnitQuaternion<f64> {
    let helper = if axis.y.abs() > 0.9 {
        Vec3::z()
    } else {
        Vec3::y()
    };
    let y = (helper - axis * axis.dot(&helper)).normalize();
    let z = axis.cross(&y);
    UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_basis_unchecked(&[*axis, y, z]))
}
