//! Hencky's clamped circular membrane under a uniform lateral pressure, built as thin
//! tetrahedral layers over a structured disk: the membrane acceptance test and
//! `examples/hencky_refinement.rs` (which includes this file) share it.
//!
//! Hencky (1915): a membrane without bending stiffness, clamped on a circle of radius a,
//! under a lateral pressure p, deflects at its centre by w0 = 0.662 a (p a / (E t))^(1/3)
//! for ν = 0.3. The pressure is a dead vertical load here (nodal forces from each node's
//! tributary area on the flat disk), which is what Hencky's lateral load is.

use softsense::fem::material::Material;
use softsense::fem::shell::{extrude, ShellParams, ShellSide, SurfaceMesh};
use softsense::fem::solve::{Formulation, MappedPoint, NewtonParams, PointLoad, Problem};
use softsense::fem::FemResult;
use std::time::Instant;

/// One membrane case (SI).
#[derive(Debug, Clone, Copy)]
pub struct MembraneCase {
    /// Radius a (m).
    pub radius: f64,
    /// Thickness t (m).
    pub thickness: f64,
    /// Young's modulus E (Pa); ν is 0.3, the value Hencky's 0.662 is for.
    pub young: f64,
    /// Lateral pressure p (Pa).
    pub pressure: f64,
    /// Rings of the disk triangulation (ring k has 6k nodes).
    pub rings: usize,
    /// Tetrahedral layers through the thickness.
    pub layers: usize,
    /// Element formulation.
    pub formulation: Formulation,
    /// Continuation steps from the flat state (load fractions (k/n)^3, so that the
    /// deflection, which grows as p^(1/3), grows about evenly).
    pub steps: usize,
}

impl MembraneCase {
    /// The acceptance case: a = 0.1 m, t = 0.3 mm (t/a = 0.003), E = 1 MPa, and p such
    /// that Hencky's w0 = 0.15 a = 15 mm, 50 thicknesses: bending is negligible.
    pub fn acceptance(rings: usize, layers: usize, formulation: Formulation) -> Self {
        let (radius, thickness, young) = (0.1, 3e-4, 1e6);
        let ratio = (0.15_f64 / 0.662).powi(3); // p a / (E t)
        Self {
            radius,
            thickness,
            young,
            pressure: ratio * young * thickness / radius,
            rings,
            layers,
            formulation,
            steps: 8,
        }
    }

    /// Hencky's centre deflection (m).
    pub fn hencky_w0(&self) -> f64 {
        let q = self.pressure * self.radius / (self.young * self.thickness);
        0.662 * self.radius * q.cbrt()
    }
}

/// What a solve of a case gives.
#[derive(Debug, Clone, Copy)]
pub struct MembraneResult {
    /// The FE centre deflection (m), the mean over the centre node's layer copies.
    pub w0: f64,
    /// Its relative error against Hencky's.
    pub error: f64,
    /// Nodes and tetrahedra of the mesh.
    pub nodes: usize,
    /// Tetrahedra.
    pub tets: usize,
    /// Newton iterations over all continuation steps.
    pub iterations: usize,
    /// Wall time of the whole solve, mesh included (s).
    pub seconds: f64,
}

/// Builds and solves `case`.
pub fn solve_membrane(case: &MembraneCase) -> FemResult<MembraneResult> {
    let start = Instant::now();
    let surface = SurfaceMesh::disk(case.radius, case.rings)?;
    let params = ShellParams {
        thickness: case.thickness,
        layers: case.layers,
        side: ShellSide::Centred,
        tension: 0.0,
    };
    let shell = extrude(&surface, &params)?;
    let (n, copies) = (surface.nodes.len(), case.layers + 1);
    let material = Material::new(case.young, 0.3)?;
    let mut problem = Problem::new(shell.mesh, material, case.formulation);
    problem.fixed = shell.marked;
    // Tributary areas on the flat disk, shared equally by a node's layer copies.
    let mut area = vec![0.0; n];
    for t in &surface.triangles {
        let [a, b, c] = t.map(|i| surface.nodes[i]);
        let twice = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        for &i in t {
            area[i] += twice.abs() / 6.0;
        }
    }
    let loads: Vec<PointLoad> = (0..n * copies)
        .map(|v| PointLoad {
            at: MappedPoint::node(v),
            force: [0.0, 0.0, -case.pressure * area[v % n] / copies as f64],
        })
        .collect();
    let newton = NewtonParams {
        max_iterations: 60,
        ..NewtonParams::default()
    };
    let mut solution = None;
    let mut iterations = 0;
    for k in 1..=case.steps {
        let s = (k as f64 / case.steps as f64).powi(3);
        problem.loads = (loads.iter())
            .map(|l| PointLoad {
                at: l.at,
                force: l.force.map(|f| s * f),
            })
            .collect();
        let next = match &solution {
            None => problem.solve_static(&newton)?,
            Some(prev) => problem.solve_static_from(&newton, prev)?,
        };
        iterations += next.iterations;
        solution = Some(next);
    }
    let solution = solution.expect("at least one step");
    // Node 0 of the disk is its centre.
    let w0 = -(0..copies)
        .map(|k| solution.displacement[k * n][2])
        .sum::<f64>()
        / copies as f64;
    Ok(MembraneResult {
        w0,
        error: w0 / case.hencky_w0() - 1.0,
        nodes: problem.mesh.num_nodes(),
        tets: problem.mesh.tets.len(),
        iterations,
        seconds: start.elapsed().as_secs_f64(),
    })
}
