//! The compressible Neo-Hookean tetrahedron: an analytic uniaxial stretch, finite
//! differences of the energy and the forces, frame invariance, the small-strain limit
//! against the corotational element, and Newton on the bundled robot.

use crate::common;
use nalgebra::{Matrix3, Rotation3, Vector3};
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::model::Model;
use softsense::fem::neohookean::{compute_energy_density, compute_stiffness};
use softsense::fem::solve::{
    CableControl, Formulation, MappedPoint, NewtonParams, PointLoad, Problem, Solution,
};
use softsense::fem::tet4::{ElementState, Tangent, TetRest, ALL_BLOCKS};
use softsense::fem::{FemError, FemResult};

/// Deterministic pseudo-random numbers in [-1, 1).
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn material() -> Material {
    Material::new(1e4, 0.35).unwrap()
}

fn element() -> (TetRest, [[f64; 3]; 4]) {
    let rest = [
        [0.0, 0.0, 0.0],
        [1.0, 0.1, 0.0],
        [0.2, 0.9, 0.1],
        [0.1, 0.2, 1.1],
    ];
    (TetRest::new(0, rest).unwrap(), rest)
}

/// `q x + t` for each corner.
fn apply(q: &Matrix3<f64>, t: [f64; 3], x: &[[f64; 3]; 4]) -> [[f64; 3]; 4] {
    x.map(|p| {
        let r = q * Vector3::from(p);
        [r[0] + t[0], r[1] + t[1], r[2] + t[2]]
    })
}

/// The rest corners moved by up to `amount` at random, then rotated.
fn deformed(rest: &[[f64; 3]; 4], amount: f64, seed: &mut u64) -> [[f64; 3]; 4] {
    let mut x = *rest;
    for c in x.iter_mut().flatten() {
        *c += amount * lcg(seed);
    }
    let axis = Vector3::new(lcg(seed), lcg(seed), lcg(seed));
    apply(
        &Rotation3::new(axis * 2.0).into_inner(),
        [0.3, -0.1, 0.2],
        &x,
    )
}

fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |a, c| a.max(c.abs()))
}

/// Closed-form W of F = diag(s, t, t), written out here and not taken from the library.
fn uniaxial_energy_density(m: &Material, s: f64, t: f64) -> f64 {
    let ln_j = (s * t * t).ln();
    0.5 * m.mu() * (s * s + 2.0 * t * t - 3.0) - m.mu() * ln_j + 0.5 * m.lambda() * ln_j * ln_j
}

/// The lateral stretch t of a uniaxial stretch s: the root of the lateral nominal stress
/// P_22 = μ (t − 1/t) + λ ln(s t²) / t = 0, by bisection (P_22 rises with t).
fn lateral_stretch(m: &Material, s: f64) -> f64 {
    let p22 = |t: f64| m.mu() * (t - 1.0 / t) + m.lambda() * (s * t * t).ln() / t;
    let (mut lo, mut hi) = (1e-3, 1e3);
    assert!(p22(lo) < 0.0 && p22(hi) > 0.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if p22(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[test]
fn neo_hookean_uniaxial_stretch_gives_the_closed_form_nominal_stress() {
    let m = material();
    // A unit cube with its interior nodes displaced: the homogeneous stretch holds on any mesh.
    let mut mesh = TetMesh::structured_box([0.0; 3], [1.0; 3], [3, 3, 3]).unwrap();
    let mut seed = 9;
    for p in &mut mesh.nodes_in_rest {
        if p.iter().all(|&c| c > 1e-9 && c < 1.0 - 1e-9) {
            p.iter_mut().for_each(|c| *c += 0.08 * lcg(&mut seed));
        }
    }
    let mut problem = Problem::new(mesh.clone(), m, Formulation::NeoHookean);
    problem.fixed = mesh.nodes_in_box([-1.0; 3], [1e-9, 2.0, 2.0]);
    for s in [0.6, 1.3, 2.0] {
        let t = lateral_stretch(&m, s);
        let x: Vec<[f64; 3]> = (mesh.nodes_in_rest.iter())
            .map(|p| [s * p[0], t * p[1], t * p[2]])
            .collect();
        let mut solver = problem.solver().unwrap();
        solver.assemble(&x, Tangent::Consistent).unwrap();
        let f = &solver.internal_force;
        // The face x = 1 carries the axial nominal stress times its rest area (1 m²);
        // y = 1 carries nothing, and inner nodes are in equilibrium.
        let on = |k: usize| -> Vec<usize> {
            let (mut lo, mut hi) = ([-1.0; 3], [2.0; 3]);
            (lo[k], hi[k]) = (1.0 - 1e-9, 1.0 + 1e-9);
            mesh.nodes_in_box(lo, hi)
        };
        let axial: f64 = on(0).iter().map(|&v| f[3 * v]).sum();
        let lateral: f64 = on(1).iter().map(|&v| f[3 * v + 1]).sum();
        let p11 = m.mu() * (s - 1.0 / s) + m.lambda() * (s * t * t).ln() / s;
        // The same stress as the slope of the energy along the uniaxial path (P_22 = 0
        // there, so dW/ds = P_11).
        let h = 1e-6;
        let slope = (uniaxial_energy_density(&m, s + h, lateral_stretch(&m, s + h))
            - uniaxial_energy_density(&m, s - h, lateral_stretch(&m, s - h)))
            / (2.0 * h);
        let inner = mesh.nodes_in_box([1e-9; 3], [1.0 - 1e-9; 3]);
        let residual = max_abs(inner.iter().flat_map(|&v| f[3 * v..3 * v + 3].to_vec()));
        println!(
            "s {s}: t {t:.6}, P11 {p11:.6e} Pa, face force {axial:.6e} N, dW/ds {slope:.6e}, \
             lateral {lateral:.1e}, inner {residual:.1e}"
        );
        assert!((axial - p11).abs() < 1e-10 * p11.abs(), "s {s}");
        assert!((slope - p11).abs() < 1e-6 * p11.abs(), "s {s}: dW/ds");
        assert!(lateral.abs() < 1e-10 * p11.abs() && residual < 1e-10 * p11.abs());
        // One element's Cauchy stress: diag(P11 s / J, 0, 0).
        let (e, rest) = element();
        let fx = Matrix3::new(s, 0.0, 0.0, 0.0, t, 0.0, 0.0, 0.0, t);
        let state = e.neo_hookean(0, &m, &apply(&fx, [0.0; 3], &rest));
        let want = Matrix3::new(p11 / (t * t), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        assert!((state.unwrap().stress - want).amax() < 1e-10 * p11.abs());
    }
}

#[test]
fn neo_hookean_patch_test_reproduces_a_large_homogeneous_deformation() {
    let mesh = TetMesh::structured_box([0.0; 3], [1.0; 3], [3, 3, 3]).unwrap();
    let mut p = Problem::new(mesh.clone(), material(), Formulation::NeoHookean);
    // 25% stretch, 10% squeeze, shears of 5-10%; the inner nodes start at rest.
    let f = Matrix3::new(1.25, 0.1, 0.0, -0.05, 0.9, 0.08, 0.04, 0.0, 1.1);
    let at = |q: [f64; 3]| f * Vector3::from(q);
    let mut inner = Vec::new();
    for (v, q) in mesh.nodes_in_rest.iter().enumerate() {
        if q.iter().any(|&c| !(1e-9..=1.0 - 1e-9).contains(&c)) {
            let y = at(*q);
            p.prescribed
                .push((v, [y[0] - q[0], y[1] - q[1], y[2] - q[2]]));
        } else {
            inner.push(v);
        }
    }
    let params = NewtonParams {
        load_steps: 4,
        ..Default::default()
    };
    let sol = p.solve_static(&params).unwrap();
    assert!(sol.converged && !inner.is_empty());
    for v in inner {
        let want = at(mesh.nodes_in_rest[v]);
        let err = max_abs((0..3).map(|k| sol.positions[v][k] - want[k]));
        assert!(err < 1e-10, "node {v}: {err:e}");
    }
}

/// Largest |a - b| over the largest |b| of two 12x12 matrices.
fn relative_difference(a: &[[f64; 12]; 12], b: &[[f64; 12]; 12]) -> f64 {
    let diff = max_abs(
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .map(|(x, y)| x - y),
    );
    diff / max_abs(b.iter().flatten().copied())
}

#[test]
fn neo_hookean_tangent_and_forces_equal_central_differences() {
    let (e, rest) = element();
    let m = material();
    let mut seed = 17;
    let h = 1e-6;
    let (mut worst_k, mut worst_f) = (0.0f64, 0.0f64);
    let force = |y: &[[f64; 3]; 4]| e.neo_hookean(0, &m, y).unwrap().force;
    let energy = |y: &[[f64; 3]; 4]| {
        e.volume * compute_energy_density(&m, &e.neo_hookean_gradient(0, y).unwrap())
    };
    for _ in 0..10 {
        let x = deformed(&rest, 0.25, &mut seed);
        let state = e.neo_hookean(0, &m, &x).unwrap();
        let mut fd_k = [[0.0; 12]; 12];
        let mut fd_f = [0.0; 12];
        for col in 0..12 {
            let (mut xp, mut xm) = (x, x);
            xp[col / 3][col % 3] += h;
            xm[col / 3][col % 3] -= h;
            let (fp, fm) = (force(&xp), force(&xm));
            (0..12).for_each(|row| fd_k[row][col] = (fp[row] - fm[row]) / (2.0 * h));
            fd_f[col] = (energy(&xp) - energy(&xm)) / (2.0 * h);
        }
        worst_k = worst_k.max(relative_difference(&state.tangent, &fd_k));
        let df = max_abs(state.force.iter().zip(&fd_f).map(|(a, b)| a - b));
        worst_f = worst_f.max(df / max_abs(fd_f));
        // The exact Hessian of the energy is symmetric.
        let k = &state.tangent;
        let asym = max_abs((0..144).map(|i| k[i / 12][i % 12] - k[i % 12][i / 12]));
        assert!(asym < 1e-12 * max_abs(k.iter().flatten().copied()));
    }
    println!("relative error: tangent {worst_k:.2e}, force {worst_f:.2e}");
    assert!(
        worst_k < 1e-6,
        "tangent vs central differences: {worst_k:e}"
    );
    assert!(worst_f < 1e-6, "force vs central differences: {worst_f:e}");
}

/// The element with its projected (positive semi-definite) tangent.
fn with_projected_tangent(e: &TetRest, tet: usize, x: &[[f64; 3]; 4]) -> FemResult<ElementState> {
    let mut out = ElementState::default();
    let f = e.neo_hookean_gradient(tet, x)?;
    e.neo_hookean_into(&material(), &f, Tangent::Definite, ALL_BLOCKS, &mut out);
    Ok(out)
}

/// Eigenvalues of a 12x12 element matrix.
fn eigenvalues(k: &[[f64; 12]; 12]) -> Vec<f64> {
    let k = nalgebra::DMatrix::from_fn(12, 12, |i, j| k[i][j]);
    k.symmetric_eigen().eigenvalues.iter().copied().collect()
}

#[test]
fn projected_neo_hookean_tangent_is_positive_semidefinite_and_exact_where_the_hessian_is() {
    let (e, rest) = element();
    let m = material();
    // Squeezed to half its size in every direction: the consistent tangent is indefinite.
    let squeezed = apply(&(Matrix3::identity() * 0.5), [0.0; 3], &rest);
    let consistent = e.neo_hookean(0, &m, &squeezed).unwrap();
    let projected = with_projected_tangent(&e, 7, &squeezed).unwrap();
    let scale = max_abs(consistent.tangent.iter().flatten().copied());
    let low = |k| eigenvalues(k).into_iter().fold(f64::INFINITY, f64::min);
    assert!(low(&consistent.tangent) < -1e-3 * scale);
    assert!(low(&projected.tangent) > -1e-12 * scale);
    assert_eq!(consistent.force, projected.force);
    // Under a pure stretch the energy is strictly convex in F (every eigenvalue of the
    // symmetric 9x9 dP/dF is positive): the projection changes nothing.
    let stretch = Matrix3::new(1.1, 0.02, 0.0, 0.02, 1.05, 0.01, 0.0, 0.01, 1.2);
    let h = compute_stiffness(&m, &stretch);
    assert!((h - h.transpose()).amax() < 1e-12 * h.amax());
    assert!(h.symmetric_eigen().eigenvalues.min() > 1e-3 * h.amax());
    let x = apply(&stretch, [0.1, 0.0, 0.0], &rest);
    let c = e.neo_hookean(0, &m, &x).unwrap();
    let p = with_projected_tangent(&e, 0, &x).unwrap();
    let diff = relative_difference(&p.tangent, &c.tangent);
    assert!(diff < 1e-12, "{diff:e}");
}

#[test]
fn neo_hookean_force_is_zero_for_rigid_motions_and_rotates_with_the_body() {
    let (e, rest) = element();
    let m = material();
    let mut seed = 23;
    for _ in 0..20 {
        let axis = Vector3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed));
        let q = Rotation3::new(axis * 3.0).into_inner();
        let x = apply(&q, [lcg(&mut seed), lcg(&mut seed), 0.5], &rest);
        let f = e.neo_hookean(0, &m, &x).unwrap().force;
        assert!(max_abs(f) < 1e-10 * m.young() * e.volume, "{f:?}");
    }
    let x = deformed(&rest, 0.25, &mut seed);
    let f0 = e.neo_hookean(0, &m, &x).unwrap();
    let q = Rotation3::new(Vector3::new(0.4, -1.1, 0.7)).into_inner();
    let f1 = e
        .neo_hookean(0, &m, &apply(&q, [0.5, 0.0, -2.0], &x))
        .unwrap();
    let scale = max_abs(f0.force);
    assert!(scale > 1.0);
    for a in 0..4 {
        let want = q * Vector3::from_column_slice(&f0.force[3 * a..3 * a + 3]);
        let err = max_abs((0..3).map(|k| f1.force[3 * a + k] - want[k]));
        assert!(err < 1e-10 * scale, "node {a}: {err:e}");
    }
    let sigma = q * f0.stress * q.transpose();
    assert!((f1.stress - sigma).amax() < 1e-10 * f0.stress.amax());
}

#[test]
fn inverted_neo_hookean_element_is_an_error_naming_it() {
    let (e, rest) = element();
    let mut x = rest;
    x[3][2] = -1.0;
    assert!(matches!(
        e.neo_hookean(7, &material(), &x),
        Err(FemError::InvertedElement { tet: 7, .. })
    ));
    assert!(matches!(
        with_projected_tangent(&e, 7, &x),
        Err(FemError::InvertedElement { tet: 7, .. })
    ));
}

#[test]
fn neo_hookean_element_at_small_strain_is_the_linear_element() {
    let (e, rest) = element();
    let m = material();
    let k0 = e.stiffness(&m);
    let at_rest = e.neo_hookean(0, &m, &rest).unwrap();
    assert!(relative_difference(&at_rest.tangent, &k0) < 1e-12);
    assert!(max_abs(at_rest.force) < 1e-12 * m.young());
    let mut seed = 31;
    let u = [0; 4].map(|_| [0; 3].map(|_| 1e-7 * lcg(&mut seed)));
    let x = [0, 1, 2, 3].map(|a| [0, 1, 2].map(|k| rest[a][k] + u[a][k]));
    let nh = e.neo_hookean(0, &m, &x).unwrap().force;
    let lin = e.small_strain(&m, &u).force;
    let diff = max_abs(nh.iter().zip(&lin).map(|(a, b)| a - b)) / max_abs(lin);
    println!("small-strain element force difference {diff:.2e}");
    assert!(diff < 1e-5, "{diff:e}");
}

/// The bundled robot with `formulation`, its gravity and cable shortening times `scale`,
/// and a tip weight of `tip_newton` times `scale` (N, downwards).
fn robot(formulation: Formulation, scale: f64, tip_newton: f64) -> Problem {
    let path = common::project_root().join("meshes/models/robot.toml");
    let mut p = Model::load(&path, None).unwrap().problem;
    p.formulation = formulation;
    p.gravity = p.gravity.map(|g| g * scale);
    for c in &mut p.cables {
        c.control = match c.control {
            CableControl::Displacement(d) => CableControl::Displacement(d * scale),
            CableControl::Force(f) => CableControl::Force(f * scale),
        };
    }
    let tip = MappedPoint::locate(&p.mesh, [0.0, 0.0, 0.125], 1e-3).unwrap();
    p.loads.push(PointLoad {
        at: tip,
        force: [0.0, 0.0, -tip_newton * scale],
    });
    p
}

/// Largest nodal displacement difference of `a` from `b`, relative to `b`'s largest.
fn displacement_difference(a: &Solution, b: &Solution) -> (f64, f64) {
    let diff = (a.displacement.iter().zip(&b.displacement))
        .map(|(u, v)| (0..3).map(|k| (u[k] - v[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    let size = (b.displacement.iter())
        .map(|u| u.iter().map(|c| c * c).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    (diff / size, size)
}

#[test]
fn neo_hookean_robot_at_small_load_equals_the_corotational_robot() {
    // The residual of both formulations stalls near 2e-12 N (positions of ~0.1 m carry
    // ~1e-17 m of round-off, 1e-14 in F): the default 1e-12 N is below that floor.
    let params = NewtonParams {
        abs_tol: 1e-11,
        ..Default::default()
    };
    let solve = |f| robot(f, 1e-6, 0.5).solve_static(&params).unwrap();
    let (nh, cr) = (
        solve(Formulation::NeoHookean),
        solve(Formulation::Corotational),
    );
    assert!(nh.converged && cr.converged);
    let (rel, size) = displacement_difference(&nh, &cr);
    let tension = (nh.cable_tension[0] - cr.cable_tension[0]).abs() / cr.cable_tension[0].abs();
    println!(
        "loads 1e-6 of normal: largest displacement {size:.3e} m, relative difference \
         {rel:.2e}, cable tension {tension:.2e}"
    );
    assert!(rel < 1e-6, "displacements differ by {rel:e} relative");
    assert!(
        tension < 1e-6,
        "cable tensions differ by {tension:e} relative"
    );
}

#[test]
fn neo_hookean_robot_converges_under_its_own_load_close_to_the_corotational_answer() {
    let params = NewtonParams::default();
    let solve = |f| robot(f, 1.0, 0.5).solve_static(&params).unwrap();
    let (nh, cr) = (
        solve(Formulation::NeoHookean),
        solve(Formulation::Corotational),
    );
    assert!(nh.converged && cr.converged);
    let (rel, size) = displacement_difference(&nh, &cr);
    println!(
        "gravity, 10 mm cable, 0.5 N tip weight: largest displacement {size:.3e} m, \
         Neo-Hookean differs by {rel:.2e} relative ({} Newton iterations, corotational {})",
        nh.iterations, cr.iterations
    );
    assert!(rel > 1e-5 && rel < 0.1, "relative difference {rel:e}");
}

#[test]
fn solver_falls_back_to_the_projected_neo_hookean_tangent_when_the_consistent_one_is_indefinite() {
    let mesh = TetMesh::structured_box([0.0; 3], [1.0; 3], [2, 2, 2]).unwrap();
    let mut p = Problem::new(mesh.clone(), material(), Formulation::NeoHookean);
    p.fixed = mesh.nodes_in_box([-1.0; 3], [2.0, 2.0, 1e-9]);
    // Every element squeezed to half its size: the consistent tangent is indefinite.
    let x: Vec<[f64; 3]> = (mesh.nodes_in_rest.iter())
        .map(|q| q.map(|c| 0.5 * c))
        .collect();
    let mut solver = p.solver().unwrap();
    solver.assemble(&x, Tangent::Consistent).unwrap();
    assert!(matches!(
        solver.factorize(),
        Err(FemError::NotPositiveDefinite { .. })
    ));
    solver.tangent_at(&x, Tangent::Consistent).unwrap();
}
