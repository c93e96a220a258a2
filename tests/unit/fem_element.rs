//! Element and solver physics: patch test, corotational invariances, consistent tangent,
//! large rotation, singular systems and inversion.

use nalgebra::{Matrix3, Rotation3, Vector3};
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::solve::{Formulation, MappedPoint, NewtonParams, PointLoad, Problem};
use softsense::fem::tet4::{Tangent, TetRest};
use softsense::fem::FemError;

/// Deterministic pseudo-random numbers in [-1, 1).
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// A box mesh with interior nodes moved randomly by up to `amount` of the cell size.
fn distorted_box(n: usize, amount: f64, seed: u64) -> TetMesh {
    let mut m = TetMesh::structured_box([0.0; 3], [1.0, 1.0, 1.0], [n, n, n]).unwrap();
    let h = 1.0 / n as f64;
    let mut s = seed;
    for p in &mut m.nodes_in_rest {
        if p.iter().all(|&c| c > 1e-9 && c < 1.0 - 1e-9) {
            for c in p.iter_mut() {
                *c += amount * h * lcg(&mut s);
            }
        }
    }
    m.quality().expect("distortion keeps every element valid");
    m
}

fn linear_field(p: [f64; 3]) -> [f64; 3] {
    let a = [
        [1e-3, 2e-3, -1e-3],
        [0.5e-3, -2e-3, 3e-3],
        [-1e-3, 1e-3, 2e-3],
    ];
    let b = [1e-3, -2e-3, 0.5e-3];
    [0, 1, 2].map(|i| b[i] + (0..3).map(|j| a[i][j] * p[j]).sum::<f64>())
}

#[test]
fn patch_test_reproduces_a_linear_field_inside_distorted_meshes() {
    for (n, seed) in [(3, 1), (4, 7), (5, 42)] {
        let mesh = distorted_box(n, 0.3, seed);
        let mut p = Problem::new(
            mesh.clone(),
            Material::new(1e5, 0.3).unwrap(),
            Formulation::SmallStrain,
        );
        let mut interior = Vec::new();
        for (v, x) in mesh.nodes_in_rest.iter().enumerate() {
            if x.iter().any(|&c| !(1e-9..=1.0 - 1e-9).contains(&c)) {
                p.prescribed.push((v, linear_field(*x)));
            } else {
                interior.push(v);
            }
        }
        assert!(!interior.is_empty());
        let sol = p.solve_static(&NewtonParams::default()).unwrap();
        for v in interior {
            let want = linear_field(mesh.nodes_in_rest[v]);
            for (k, wk) in want.iter().enumerate() {
                let err = (sol.displacement[v][k] - wk).abs();
                assert!(
                    err < 1e-10 * 3e-3 + 1e-16,
                    "node {v} comp {k}: error {err:e}"
                );
            }
        }
        // The stress is the constant stress of the linear field everywhere.
        let vm0 = sol.von_mises[0];
        assert!(sol.von_mises.iter().all(|v| (v - vm0).abs() < 1e-8 * vm0));
    }
}

fn element() -> (TetRest, [[f64; 3]; 4], Material) {
    let rest = [
        [0.0, 0.0, 0.0],
        [1.0, 0.1, 0.0],
        [0.2, 0.9, 0.1],
        [0.1, 0.2, 1.1],
    ];
    (
        TetRest::new(0, rest).unwrap(),
        rest,
        Material::new(1e4, 0.35).unwrap(),
    )
}

fn apply(q: &Matrix3<f64>, t: [f64; 3], x: &[[f64; 3]; 4]) -> [[f64; 3]; 4] {
    x.map(|p| {
        let r = q * Vector3::from(p);
        [r[0] + t[0], r[1] + t[1], r[2] + t[2]]
    })
}

#[test]
fn corotational_force_is_zero_for_any_rigid_motion() {
    let (e, rest, m) = element();
    let mut s = 3;
    for _ in 0..20 {
        let axis = Vector3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s));
        let q = Rotation3::new(axis * 3.0).into_inner();
        let x = apply(&q, [lcg(&mut s), lcg(&mut s), lcg(&mut s)], &rest);
        let f = e
            .corotational(0, &m, &x, Tangent::Consistent)
            .unwrap()
            .force;
        let scale = m.young() * e.volume;
        assert!(f.iter().all(|c| c.abs() < 1e-10 * scale), "{f:?}");
    }
}

#[test]
fn rotating_a_deformed_state_rotates_its_internal_forces() {
    let (e, rest, m) = element();
    let deformed = [rest[0], [1.2, 0.0, 0.1], [0.3, 0.8, 0.0], [0.0, 0.3, 1.3]];
    let f0 = e
        .corotational(0, &m, &deformed, Tangent::Consistent)
        .unwrap()
        .force;
    let q = Rotation3::new(Vector3::new(0.4, -1.1, 0.7)).into_inner();
    let f1 = e
        .corotational(
            0,
            &m,
            &apply(&q, [0.5, 0.0, -2.0], &deformed),
            Tangent::Consistent,
        )
        .unwrap()
        .force;
    let scale = f0.iter().fold(0.0f64, |a, c| a.max(c.abs()));
    assert!(scale > 1.0);
    for a in 0..4 {
        let want = q * Vector3::new(f0[3 * a], f0[3 * a + 1], f0[3 * a + 2]);
        for k in 0..3 {
            assert!((f1[3 * a + k] - want[k]).abs() < 1e-10 * scale);
        }
    }
}

#[test]
fn corotational_tangent_matches_finite_differences() {
    let (e, rest, m) = element();
    let q = Rotation3::new(Vector3::new(0.3, 0.5, -0.2)).into_inner();
    let x = apply(
        &q,
        [0.0; 3],
        &[
            rest[0],
            [1.15, 0.05, 0.1],
            [0.25, 0.8, 0.0],
            [0.05, 0.3, 1.2],
        ],
    );
    let k = e
        .corotational(0, &m, &x, Tangent::Consistent)
        .unwrap()
        .tangent;
    let h = 1e-6;
    let mut max_err: f64 = 0.0;
    let mut max_k: f64 = 0.0;
    for col in 0..12 {
        let mut xp = x;
        let mut xm = x;
        xp[col / 3][col % 3] += h;
        xm[col / 3][col % 3] -= h;
        let fp = e
            .corotational(0, &m, &xp, Tangent::Consistent)
            .unwrap()
            .force;
        let fm = e
            .corotational(0, &m, &xm, Tangent::Consistent)
            .unwrap()
            .force;
        for row in 0..12 {
            let fd = (fp[row] - fm[row]) / (2.0 * h);
            max_err = max_err.max((fd - k[row][col]).abs());
            max_k = max_k.max(k[row][col].abs());
        }
    }
    assert!(
        max_err < 1e-6 * max_k,
        "tangent error {max_err:e} vs scale {max_k:e}"
    );
    // The SOFA-style rotated tangent R K0 R^T differs (it drops dR): the test can tell them apart.
    let kr = e
        .corotational(0, &m, &x, Tangent::Definite)
        .unwrap()
        .tangent;
    let diff = (0..12)
        .flat_map(|i| (0..12).map(move |j| (i, j)))
        .fold(0.0f64, |a, (i, j)| a.max((kr[i][j] - k[i][j]).abs()));
    assert!(diff > 1e-3 * max_k);
}

#[test]
fn inverted_element_is_an_error_naming_it() {
    let (e, rest, m) = element();
    let mut x = rest;
    x[3][2] = -1.0;
    assert!(matches!(
        e.corotational(7, &m, &x, Tangent::Consistent),
        Err(FemError::InvertedElement { tet: 7, .. })
    ));
}

fn beam(formulation: Formulation, load: f64) -> (Problem, Vec<usize>) {
    let (l, h) = (1.0, 0.1);
    let mesh = TetMesh::structured_box([0.0; 3], [l, h, h], [20, 2, 2]).unwrap();
    let mut p = Problem::new(mesh.clone(), Material::new(1e6, 0.3).unwrap(), formulation);
    p.fixed = mesh.nodes_in_box([-1e-9; 3], [1e-9, 1.0, 1.0]);
    let tip = mesh.nodes_in_box([l - 1e-9, -1.0, -1.0], [l + 1e-9, 1.0, 1.0]);
    for &v in &tip {
        p.loads.push(PointLoad {
            at: MappedPoint::node(v),
            force: [0.0, 0.0, load / tip.len() as f64],
        });
    }
    (p, tip)
}

#[test]
fn large_tip_rotation_stays_physical_where_small_strain_inflates() {
    // Small-strain deflection of 0.8 L: far beyond the linear range.
    let (lin, tip) = beam(Formulation::SmallStrain, 1.0);
    let s1 = lin.solve_static(&NewtonParams::default()).unwrap();
    let w1: f64 = tip.iter().map(|&v| s1.displacement[v][2]).sum::<f64>() / tip.len() as f64;
    let load = 0.8 / w1;
    let (lin, _) = beam(Formulation::SmallStrain, load);
    let (cor, _) = beam(Formulation::Corotational, load);
    let sl = lin.solve_static(&NewtonParams::default()).unwrap();
    let params = NewtonParams {
        load_steps: 10,
        ..Default::default()
    };
    let sc = cor.solve_static(&params).unwrap();
    assert!(sc.converged);
    let mean = |s: &softsense::fem::solve::Solution, k: usize| {
        tip.iter().map(|&v| s.positions[v][k]).sum::<f64>() / tip.len() as f64
    };
    let root = [0.0, 0.05, 0.05];
    let reach = |s: &softsense::fem::solve::Solution| {
        ((mean(s, 0) - root[0]).powi(2) + (mean(s, 2) - root[2]).powi(2)).sqrt()
    };
    // Small strain: the tip goes straight up, the beam "grows" by ~28%.
    assert!(reach(&sl) > 1.25, "small strain reach {}", reach(&sl));
    // Corotational: the beam bends, the tip comes back towards the root, length is kept.
    assert!(reach(&sc) < 1.01, "corotational reach {}", reach(&sc));
    assert!(mean(&sc, 0) < 0.95, "tip x {}", mean(&sc, 0));
    assert!(mean(&sc, 2) - 0.05 < 0.8 && mean(&sc, 2) - 0.05 > 0.3);
    // The small-strain model inflates the volume of rotated elements; the corotational one does not.
    let vol = |s: &softsense::fem::solve::Solution| {
        let m = TetMesh::new(s.positions.clone(), lin.mesh.tets.clone()).unwrap();
        m.signed_volumes().iter().sum::<f64>()
    };
    let v0 = 0.01;
    assert!(
        vol(&sl) / v0 > 1.05,
        "small strain volume ratio {}",
        vol(&sl) / v0
    );
    assert!(
        (vol(&sc) / v0 - 1.0).abs() < 0.02,
        "corotational volume ratio {}",
        vol(&sc) / v0
    );
}

#[test]
fn no_fixed_nodes_or_collinear_supports_are_singular_errors() {
    let mesh = TetMesh::structured_box([0.0; 3], [1.0, 1.0, 1.0], [2, 2, 2]).unwrap();
    let mut p = Problem::new(
        mesh,
        Material::new(1e5, 0.3).unwrap(),
        Formulation::Corotational,
    );
    p.loads.push(PointLoad {
        at: MappedPoint::node(5),
        force: [1.0, 0.0, 0.0],
    });
    assert!(matches!(
        p.solve_static(&NewtonParams::default()),
        Err(FemError::Singular(_))
    ));
    p.fixed = vec![0, 1, 2]; // the three nodes of one edge line
    assert!(matches!(
        p.solve_static(&NewtonParams::default()),
        Err(FemError::Singular(_))
    ));
    p.fixed = vec![0, 1, 3];
    assert!(p.solve_static(&NewtonParams::default()).is_ok());
}

#[cfg(feature = "parallel")]
#[test]
fn assembly_is_bitwise_identical_for_any_thread_count() {
    let mesh = distorted_box(4, 0.3, 5);
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(1e5, 0.4).unwrap(),
        Formulation::Corotational,
    );
    p.fixed = mesh.nodes_in_box([-1.0; 3], [1.0, 1.0, 1e-9]);
    let x: Vec<[f64; 3]> = mesh
        .nodes_in_rest
        .iter()
        .map(|q| [q[0] + 0.1 * q[2] * q[2], q[1], q[2] * 1.05])
        .collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut s = p.solver().unwrap();
            s.assemble(&x, Tangent::Consistent).unwrap();
            (s.values.clone(), s.internal_force.clone())
        })
    };
    let (k1, f1) = run(1);
    for t in [2, 3, 8] {
        let (k, f) = run(t);
        assert!(k.iter().zip(&k1).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(f.iter().zip(&f1).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

/// The corotational tangents column by column, straight from the derivation in the tet4
/// module docs (dF = e_j g_b^T, dR = R [w]x, (tr(S) I - S) w = axial(R^T dF - dF^T R)),
/// and R K0 R^T block by block: the reference the closed-form kernel must reproduce.
fn reference_tangent(e: &TetRest, m: &Material, x: &[[f64; 3]; 4], t: Tangent) -> [[f64; 12]; 12] {
    let f = e.deformation_gradient(x);
    let r = softsense::fem::tet4::polar_rotation(&f);
    let s = r.transpose() * f;
    let s = (s + s.transpose()) * 0.5;
    let sigma = m.stress(&(s - Matrix3::identity()));
    let mut k = [[0.0; 12]; 12];
    match t {
        Tangent::Consistent => {
            let a_inv = (Matrix3::identity() * s.trace() - s).try_inverse().unwrap();
            for b in 0..4 {
                for j in 0..3 {
                    let mut df = Matrix3::zeros();
                    df.set_row(j, &e.grads[b].transpose());
                    let mm = r.transpose() * df;
                    let ax = Vector3::new(
                        mm[(2, 1)] - mm[(1, 2)],
                        mm[(0, 2)] - mm[(2, 0)],
                        mm[(1, 0)] - mm[(0, 1)],
                    );
                    let wx = (a_inv * ax).cross_matrix();
                    let de = mm - wx * s;
                    let dp = r * wx * sigma + r * m.stress(&((de + de.transpose()) * 0.5));
                    for a in 0..4 {
                        let dfa = dp * e.grads[a] * e.volume;
                        for i in 0..3 {
                            k[3 * a + i][3 * b + j] = dfa[i];
                        }
                    }
                }
            }
        }
        Tangent::Definite => {
            let k0 = e.stiffness(m);
            for a in 0..4 {
                for b in 0..4 {
                    let blk = Matrix3::from_fn(|i, j| k0[3 * a + i][3 * b + j]);
                    let rb = r * blk * r.transpose();
                    for i in 0..3 {
                        for j in 0..3 {
                            k[3 * a + i][3 * b + j] = rb[(i, j)];
                        }
                    }
                }
            }
        }
    }
    k
}

#[test]
fn closed_form_tangents_equal_the_column_by_column_derivation() {
    let (e, rest, m) = element();
    let mut seed = 11;
    for _ in 0..20 {
        let axis = Vector3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed));
        let q = Rotation3::new(axis * 2.0).into_inner();
        let mut x = rest;
        for p in &mut x {
            for c in p.iter_mut() {
                *c += 0.15 * lcg(&mut seed);
            }
        }
        let x = apply(&q, [0.3, -0.1, 0.2], &x);
        for t in [Tangent::Consistent, Tangent::Definite] {
            let k = e.corotational(0, &m, &x, t).unwrap().tangent;
            let r = reference_tangent(&e, &m, &x, t);
            let scale = r.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
            for (p, (kr, rr)) in k.iter().zip(&r).enumerate() {
                for (q, (a, b)) in kr.iter().zip(rr).enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-12 * scale,
                        "{t:?} K[{p}][{q}]: {a:e} vs {b:e}"
                    );
                }
            }
        }
    }
}

#[test]
fn polar_rotation_is_orthonormal_and_leaves_a_symmetric_positive_stretch() {
    let mut seed = 5;
    for i in 0..200 {
        // Rotations times stretches up to 10:1, some near-rigid.
        let q = Rotation3::new(Vector3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)) * 3.0)
            .into_inner();
        let amount = if i % 2 == 0 { 1e-6 } else { 0.9 };
        let u = Matrix3::from_fn(|_, _| amount * lcg(&mut seed));
        let stretch = Matrix3::identity() + (u + u.transpose()) * 0.5;
        if stretch.symmetric_eigen().eigenvalues.min() < 0.1 {
            continue;
        }
        let f = q * stretch;
        let r = softsense::fem::tet4::polar_rotation(&f);
        // Orthonormal to a few round-offs (the iteration stops once its error is below
        // 1e-14), and the same rotation as the SVD's U Vᵀ.
        assert!(
            (r.transpose() * r - Matrix3::identity()).amax() < 1e-13,
            "R^T R at {i}: {:e}",
            (r.transpose() * r - Matrix3::identity()).amax()
        );
        let svd = f.svd(true, true);
        let uv = svd.u.unwrap() * svd.v_t.unwrap();
        assert!(
            (r - uv).amax() < 1e-13,
            "R = U Vᵀ at {i}: {:e}",
            (r - uv).amax()
        );
        assert!((r.determinant() - 1.0).abs() < 1e-12, "det R at {i}");
        assert!((r - q).amax() < 1e-10, "R recovers the rotation at {i}");
        let s = r.transpose() * f;
        assert!(
            (s - s.transpose()).amax() < 1e-10 * s.amax(),
            "S symmetric at {i}"
        );
    }
}
