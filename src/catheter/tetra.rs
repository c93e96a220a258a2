//! The catheter as a slender tetrahedral solid: the cross-check of the beam (5.2). The
//! same straight catheter, section and material as a [`Catheter`], meshed with linear
//! tetrahedra ([`TetMesh::cylinder`]), its base slice clamped, each cable a
//! [`Cable`] through the points at the beam cable's offset and angle in
//! every slice, pulled from the base and anchored in the tip slice. It shares nothing with
//! the beam but the numbers, so where the two agree the beam's element, rotations and
//! cable routing are checked by three-dimensional elasticity.
//!
//! Linear tetrahedra are too stiff in bending (shear locking) by a factor that falls with
//! the cell size; docs/catheter.md gives it for the defaults and how it converges.

use super::rig::Catheter;
use super::{CatheterError, CatheterResult};
use crate::fem::beam::BeamSection;
use crate::fem::material::Material;
use crate::fem::mesh::TetMesh;
use crate::fem::solve::{Cable, CableControl, Formulation, MappedPoint, Problem};
use crate::math::Vec3;

/// How the tetrahedral catheter is meshed.
#[derive(Clone, Debug, PartialEq)]
pub struct TetCatheterParams {
    /// Cells across the diameter (6; even, so the centreline is a row of nodes).
    pub across: usize,
    /// Cell length along the catheter over its width across (2).
    pub aspect: f64,
    /// Small-strain or corotational (corotational: large rotations, as the beam).
    pub formulation: Formulation,
}

impl Default for TetCatheterParams {
    fn default() -> Self {
        Self {
            across: 6,
            aspect: 2.0,
            formulation: Formulation::Corotational,
        }
    }
}

/// The tetrahedral catheter: its FE problem and where its centreline nodes are.
#[derive(Clone, Debug)]
pub struct TetCatheter {
    /// The FE problem: the mesh along the beam's rest axis, the base slice clamped, one
    /// force-controlled cable per beam cable (tension 0 until set).
    pub problem: Problem,
    /// Centreline node of every slice, base (0) to tip.
    pub centreline: Vec<usize>,
}

impl TetCatheter {
    /// Meshes `catheter`, whose beam must be straight at rest, as `params` say.
    pub fn new(catheter: &Catheter, params: &TetCatheterParams) -> CatheterResult<Self> {
        let bad = |what: String| CatheterError::Shape(format!("tetrahedral catheter: {what}"));
        if params.across < 2 || params.across % 2 == 1 || params.across > 64 {
            return Err(bad(format!(
                "across = {} cells: must be even, 2 to 64",
                params.across
            )));
        }
        if !(params.aspect > 0.0 && params.aspect <= 20.0) {
            return Err(bad(format!(
                "aspect = {}: must be in (0, 20]",
                params.aspect
            )));
        }
        let rest = catheter.beam.rest_state();
        let base = rest.nodes_in_world[0];
        let chord = rest.nodes_in_world.last().copied().unwrap_or(base) - base;
        let length = chord.norm();
        let axis = chord / length;
        let off_axis = (rest.nodes_in_world.iter())
            .map(|p| (p - base - axis * axis.dot(&(p - base))).norm())
            .fold(0.0, f64::max);
        if !(off_axis <= 1e-9 * length) {
            return Err(bad(format!(
                "the beam is not straight at rest (a node {off_axis:.3e} m off its chord)"
            )));
        }
        let cell = 2.0 * catheter.radius / params.across as f64;
        let along = ((length / (params.aspect * cell)).round() as usize).max(1);
        let mut mesh = TetMesh::cylinder(catheter.radius, length, params.across, along)?;
        // The cylinder runs along +x from the origin; the beam's node 0 frame carries its
        // x onto the beam's axis and its y, z onto the section axes the cables are at.
        let world_from_base = rest.world_from_node[0];
        for p in &mut mesh.nodes_in_rest {
            *p = (base + world_from_base * Vec3::from(*p)).into();
        }
        let material = solid_material(catheter)?;
        let mut problem = Problem::new(mesh, material, params.formulation);
        let row = params.across + 1;
        let node = |i: usize, j: usize, k: usize| i + (along + 1) * (j + row * k);
        let centre = params.across / 2;
        problem.fixed = (0..row * row)
            .map(|jk| node(0, jk % row, jk / row))
            .collect();
        let centreline = (0..=along).map(|i| node(i, centre, centre)).collect();
        let slice_point = |i: usize, local: Vec3| {
            let on_axis = Vec3::new(length * i as f64 / along as f64, 0.0, 0.0);
            <[f64; 3]>::from(base + world_from_base * (on_axis + local))
        };
        for (c, cable) in catheter.cables.iter().enumerate() {
            let local = Vec3::new(0.0, cable.angle.cos(), cable.angle.sin()) * cable.offset;
            let attach = (1..=along)
                .map(|i| MappedPoint::locate(&problem.mesh, slice_point(i, local), 1e-9))
                .collect::<Result<_, _>>()?;
            problem.cables.push(Cable {
                name: format!("cable{c}"),
                pull: slice_point(0, local),
                attach,
                control: CableControl::Force(0.0),
            });
        }
        Ok(Self {
            problem,
            centreline,
        })
    }
}

/// The beam's material, read back from its rigidities (EA, EI, GJ) and the catheter's
/// radius; refused unless the section is a solid circle of that radius.
fn solid_material(catheter: &Catheter) -> CatheterResult<Material> {
    let section = BeamSection::circular(catheter.radius)?;
    let s = catheter.beam.stiffness();
    let young = s.bending / section.second_moment();
    let shear = s.torsional / section.polar_moment();
    if !((s.axial / section.area() - young).abs() <= 1e-9 * young) {
        return Err(CatheterError::Shape(format!(
            "tetrahedral catheter: the beam's section is not a solid circle of radius {} m",
            catheter.radius
        )));
    }
    Ok(Material::new(young, young / (2.0 * shear) - 1.0)?)
}
