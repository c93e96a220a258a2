//! The corotational beam (`fem::beam`): Euler-Bernoulli cantilevers, a large rotation, the
//! tangent and the compliance against finite differences, insertion, a cable, and BM-2 (the
//! thesis's Table 5.1 analogue: a propped rod's contact force).

use nalgebra::{DMatrix, UnitQuaternion, Vector3};
use softsense::fem::beam::{
    BeamCable, BeamLoads, BeamMaterial, BeamModel, BeamParams, BeamRow, BeamSection, BeamState,
    NodeLoad, NodeSpring,
};
use softsense::fem::FemError;

const E: f64 = 1.4e9;
const RADIUS: f64 = 1.0e-3;
const LENGTH: f64 = 0.2;

fn rod(elements: usize) -> Result<BeamModel, FemError> {
    BeamModel::straight(
        LENGTH,
        elements,
        BeamSection::circular(RADIUS)?,
        BeamMaterial::new(E, 0.35)?,
    )
}

fn solve(model: &BeamModel, loads: &BeamLoads, steps: usize) -> Result<BeamState, FemError> {
    let params = BeamParams {
        load_steps: steps,
        max_iterations: 200,
        ..Default::default()
    };
    let sol = model.solve_static(&model.rest_state(), loads, &params)?;
    assert!(
        sol.status.is_converged(),
        "{:?} after {} iterations",
        sol.status,
        sol.iterations
    );
    Ok(sol.state)
}

fn tip_load(load: NodeLoad) -> BeamLoads {
    BeamLoads {
        nodes: vec![load],
        ..Default::default()
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn beam_cantilever_tip_force_matches_euler_bernoulli() -> Result<(), FemError> {
    for elements in [1, 8] {
        let model = rod(elements)?;
        let ei = model.stiffness().bending;
        // Small: a tip deflection of 1e-4 L.
        let p = 3.0e-4 * ei / LENGTH.powi(2);
        let state = solve(
            &model,
            &tip_load(NodeLoad::force(elements, [0.0, p, 0.0])),
            1,
        )?;
        let deflection = state.nodes_in_world[elements].y;
        let turn = BeamRow::rotation(elements, [0.0, 0.0, 1.0]).measure(&model, &state);
        let (want_d, want_t) = (
            p * LENGTH.powi(3) / (3.0 * ei),
            p * LENGTH.powi(2) / (2.0 * ei),
        );
        eprintln!(
            "{elements} elements: deflection {deflection:e} m (EB {want_d:e}), rotation {turn:e} rad (EB {want_t:e})"
        );
        assert!(rel(deflection, want_d) < 0.01);
        assert!(rel(turn, want_t) < 0.01);
    }
    Ok(())
}

#[test]
fn beam_tip_moment_rolls_the_rod_into_a_half_circle() -> Result<(), FemError> {
    let model = rod(40)?;
    let m = std::f64::consts::PI * model.stiffness().bending / LENGTH;
    let state = solve(&model, &tip_load(NodeLoad::moment(40, [0.0, 0.0, m])), 8)?;
    let tip = state.nodes_in_world[40];
    let want = Vector3::new(0.0, 2.0 * LENGTH / std::f64::consts::PI, 0.0);
    let err = (tip - want).norm() / want.y;
    eprintln!(
        "half circle: tip {:?} m, want {:?} m, error {:.3}%",
        tip.as_slice(),
        want.as_slice(),
        100.0 * err
    );
    assert!(err < 0.01);
    Ok(())
}

/// A configuration off equilibrium: nodes moved and turned by smooth, large amounts.
fn deformed(model: &BeamModel) -> BeamState {
    let mut s = model.rest_state();
    let n = s.nodes_in_world.len();
    for i in 1..n {
        let t = i as f64 / (n - 1) as f64;
        s.nodes_in_world[i] += Vector3::new(-0.01 * t * t, 0.03 * t * t, -0.02 * t.powi(3));
        let turn = Vector3::new(0.3 * t, -0.2 * t * t, 0.4 * t);
        s.world_from_node[i] = UnitQuaternion::from_scaled_axis(turn) * s.world_from_node[i];
    }
    s
}

#[test]
fn beam_tangent_matches_finite_differences_of_the_internal_force() -> Result<(), FemError> {
    let model = rod(3)?;
    let state = deformed(&model);
    let k = model.tangent_dense(&state);
    let ndof = k.nrows();
    let mut fd = DMatrix::zeros(ndof, ndof);
    for j in 0..ndof {
        let (node, kind, axis) = (j / 6, (j / 3) % 2, j % 3);
        let h = if kind == 0 { 1e-6 * LENGTH } else { 1e-6 };
        let moved = |sign: f64| {
            let mut s = state.clone();
            let mut e = Vector3::zeros();
            e[axis] = sign * h;
            if kind == 0 {
                s.nodes_in_world[node] += e;
            } else {
                s.world_from_node[node] =
                    UnitQuaternion::from_scaled_axis(e) * s.world_from_node[node];
            }
            model.internal_force(&s)
        };
        fd.set_column(j, &((moved(1.0) - moved(-1.0)) / (2.0 * h)));
    }
    // Spins do not commute: only the symmetric part is the symmetrised tangent.
    let sym = 0.5 * (&fd + fd.transpose());
    let err = (&sym - &k).abs().max() / k.abs().max();
    let asym = (&fd - fd.transpose()).abs().max() / k.abs().max();
    eprintln!("tangent vs FD: max error {err:e} of max |K|; FD asymmetry {asym:e}");
    assert!(err < 1e-6);
    Ok(())
}

#[test]
fn beam_compliance_matches_finite_differences_of_the_solve() -> Result<(), FemError> {
    let model = rod(10)?;
    let ei = model.stiffness().bending;
    // A large deflection (about 0.2 L), so W is the one of the deformed rod.
    let p = 0.6 * ei / LENGTH.powi(2);
    let row = BeamRow::translation(10, [0.0, 1.0, 0.0]);
    let at = |extra: f64| {
        solve(
            &model,
            &tip_load(NodeLoad::force(10, [0.0, p + extra, 0.0])),
            2,
        )
    };
    let state = at(0.0)?;
    let w = model
        .linearise(&state)?
        .compliance(std::slice::from_ref(&row))[(0, 0)];
    let dp = 1e-4 * p;
    let fd = (row.measure(&model, &at(dp)?) - row.measure(&model, &at(-dp)?)) / (2.0 * dp);
    let linear = LENGTH.powi(3) / (3.0 * ei);
    eprintln!(
        "tip compliance: W {w:e} m/N, FD {fd:e} m/N (linear {linear:e}); tip y {:.4} m",
        state.nodes_in_world[10].y
    );
    assert!(rel(w, fd) < 1e-4);
    assert!(w < 0.95 * linear, "the deformed rod is stiffer along y");
    Ok(())
}

#[test]
fn beam_rows_mixing_translation_and_rotation() -> Result<(), FemError> {
    let model = rod(4)?;
    let ei = model.stiffness().bending;
    let rows = [
        BeamRow::translation(4, [0.0, 1.0, 0.0]),
        BeamRow::rotation(4, [0.0, 0.0, 1.0]),
        BeamRow {
            entries: vec![(4, [0.0, 1.0, 0.0, 0.0, 0.0, LENGTH])],
        },
    ];
    let w = model.linearise(&model.rest_state())?.compliance(&rows);
    let (l, l2, l3) = (LENGTH, LENGTH.powi(2), LENGTH.powi(3));
    let want = [
        (0, 0, l3 / (3.0 * ei)),
        (0, 1, l2 / (2.0 * ei)),
        (1, 1, l / ei),
        (2, 2, l3 * (1.0 / 3.0 + 1.0 + 1.0) / ei),
    ];
    for (i, j, v) in want {
        eprintln!("W[{i}][{j}] = {:e}, Euler-Bernoulli {v:e}", w[(i, j)]);
        assert!(rel(w[(i, j)], v) < 1e-6);
    }
    // The rotation row as an effector: the tip turns by PL²/2EI under a small tip force.
    let p = 1e-4 * ei / l2;
    let state = solve(&model, &tip_load(NodeLoad::force(4, [0.0, p, 0.0])), 1)?;
    let turn = rows[1].measure(&model, &state);
    assert!(rel(turn, p * l2 / (2.0 * ei)) < 0.01);
    Ok(())
}

#[test]
fn beam_insertion_moves_the_unloaded_rod_rigidly() -> Result<(), FemError> {
    let model = rod(6)?;
    let loads = BeamLoads {
        base_from_rest: model.insertion(0.03),
        ..Default::default()
    };
    let state = solve(&model, &loads, 1)?;
    let rest = model.rest_state();
    for (i, x) in state.nodes_in_world.iter().enumerate() {
        let moved = rest.nodes_in_world[i] + Vector3::new(0.03, 0.0, 0.0);
        assert!((x - moved).norm() < 1e-12, "node {i} at {x:?}");
        assert!(state.world_from_node[i].angle_to(&rest.world_from_node[i]) < 1e-12);
    }
    Ok(())
}

#[test]
fn beam_cable_bends_the_rod_with_constant_curvature() -> Result<(), FemError> {
    let n = 10;
    let model = rod(n)?;
    let ei = model.stiffness().bending;
    let cable = BeamCable {
        offset: 0.8e-3,
        angle: 0.0,
    };
    // Small: a tip angle of about 0.02 rad.
    let t = 0.02 * ei / (cable.offset * LENGTH);
    let loads = |tension: f64| BeamLoads {
        cables: vec![(cable, tension)],
        ..Default::default()
    };
    let state = solve(&model, &loads(t), 1)?;
    for i in 1..=n {
        let x = LENGTH * i as f64 / n as f64;
        let turn = BeamRow::rotation(i, [0.0, 0.0, 1.0]).measure(&model, &state);
        let want = t * cable.offset * x / ei;
        if i == n {
            eprintln!("cable: tip angle {turn:e} rad, T r L / EI {want:e} rad");
        }
        assert!(rel(turn, want) < 0.02, "node {i}: {turn} rad, want {want}");
    }
    // The actuator row of W against the shortening's derivative at T = 0.
    let rest = model.rest_state();
    let w = model.linearise(&rest)?.compliance(&[cable.row(&rest)])[(0, 0)];
    let dt = 1e-3 * t;
    let fd = (cable.shortening(&model, &solve(&model, &loads(dt), 1)?)
        - cable.shortening(&model, &solve(&model, &loads(-dt), 1)?))
        / (2.0 * dt);
    let s = model.stiffness();
    let want = cable.offset.powi(2) * LENGTH / ei + LENGTH / s.axial;
    eprintln!("cable compliance: W_aa {w:e} m/N, FD {fd:e}, r²L/EI + L/EA {want:e}");
    assert!(rel(w, fd) < 1e-4);
    assert!(rel(w, want) < 1e-3);
    Ok(())
}

/// Euler-Bernoulli propped cantilever: clamped at 0, a prop (simple support) at `a`, the
/// tip at `l` displaced by `delta` under an unknown tip load P. Superposition of the
/// cantilever's two loads (P at l up, the prop's R at a down), with y(a) = 0:
/// P a²(3l − a)/(6EI) = R a³/(3EI), so R = P (3l − a)/(2a); the tip:
/// δ = P l³/(3EI) − R a²(3l − a)/(6EI) = P (4l³ − a(3l − a)²)/(12EI)
///   = P (l − a)²(4l − a)/(12EI). Hence
/// R = 6 EI δ (3l − a) / (a (l − a)² (4l − a)).
fn propped_reaction(ei: f64, l: f64, a: f64, delta: f64) -> f64 {
    6.0 * ei * delta * (3.0 * l - a) / (a * (l - a).powi(2) * (4.0 * l - a))
}

/// The FE contact force at node `contact` (a point obstacle on the +y side, touching at
/// rest) with the tip held at y = `delta`: the tip row is an effector with its force P
/// unknown, the contact row (−y, the obstacle's push) unilateral, 0 ≤ gap ⊥ λ ≥ 0. Each
/// round solves the nonlinear statics under (P, λ), then corrects both from W = H K⁻¹ Hᵀ at
/// that configuration; a negative λ would release the contact (λ = 0, the tip row alone).
fn propped_fe(model: &BeamModel, contact: usize, delta: f64) -> Result<f64, FemError> {
    let tip = model.node_count() - 1;
    let rows = [
        BeamRow::translation(tip, [0.0, 1.0, 0.0]),
        BeamRow::translation(contact, [0.0, -1.0, 0.0]),
    ];
    let (mut p, mut lambda) = (0.0, 0.0);
    let mut state = model.rest_state();
    for _ in 0..30 {
        let mut loads = BeamLoads::default();
        loads.nodes.extend(rows[0].loads(p));
        loads.nodes.extend(rows[1].loads(lambda));
        let sol = model.solve_static(&state, &loads, &BeamParams::default())?;
        assert!(sol.status.is_converged(), "{:?}", sol.status);
        state = sol.state;
        let miss = [
            delta - rows[0].measure(model, &state),
            -rows[1].measure(model, &state),
        ];
        if miss[0].abs() < 1e-10 * delta && miss[1].abs() < 1e-10 * delta {
            assert!(lambda >= 0.0);
            return Ok(lambda);
        }
        let w = model.linearise(&state)?.compliance(&rows);
        let det = w[(0, 0)] * w[(1, 1)] - w[(0, 1)] * w[(1, 0)];
        let dp = (w[(1, 1)] * miss[0] - w[(0, 1)] * miss[1]) / det;
        let dl = (w[(0, 0)] * miss[1] - w[(1, 0)] * miss[0]) / det;
        p += dp;
        lambda += dl;
        if lambda < 0.0 {
            lambda = 0.0;
            p += (miss[0] - w[(0, 0)] * dp) / w[(0, 0)];
        }
    }
    panic!("the propped rod did not converge");
}

/// BM-2: rod L = 210 mm, E = 1.4 GPa, solid circle of radius 1.5 mm (EI = 5.57e-3 N m²),
/// 20 elements. Props A1, A2, A3 at 0.45 L, 0.6 L, 0.75 L (nodes 9, 12, 15): the reaction
/// grows as the prop nears the tip (past its minimum near 0.35 L), as the table's does
/// from A1 to A3. Tip targets B1, B2, B3: 6, 12, 18 mm toward the props' side, for forces
/// of 0.1 to 1 N like the table's.
#[test]
fn beam_bm2_propped_rod_contact_forces_match_euler_bernoulli() -> Result<(), FemError> {
    let (l, n) = (0.21, 20);
    let model = BeamModel::straight(
        l,
        n,
        BeamSection::circular(1.5e-3)?,
        BeamMaterial::new(1.4e9, 0.35)?,
    )?;
    let ei = model.stiffness().bending;
    let contacts = [9, 12, 15];
    let targets = [6.0e-3, 12.0e-3, 18.0e-3];
    let mut fe = [[0.0; 3]; 3];
    let mut analytic = [[0.0; 3]; 3];
    for (b, &delta) in targets.iter().enumerate() {
        for (a, &node) in contacts.iter().enumerate() {
            let at = l * node as f64 / n as f64;
            analytic[b][a] = propped_reaction(ei, l, at, delta);
            fe[b][a] = propped_fe(&model, node, delta)?;
        }
    }
    eprintln!("BM-2 contact force (mN): target, contact, FE, analytic, error");
    let mut errors = Vec::new();
    for b in 0..3 {
        for a in 0..3 {
            let err = rel(fe[b][a], analytic[b][a]);
            errors.push(err);
            eprintln!(
                "  B{} A{}: {:7.1} {:7.1} {:5.2}%",
                b + 1,
                a + 1,
                1e3 * fe[b][a],
                1e3 * analytic[b][a],
                100.0 * err
            );
        }
    }
    let accuracy = 1.0 - errors.iter().sum::<f64>() / errors.len() as f64;
    let worst = errors.iter().cloned().fold(0.0, f64::max);
    eprintln!(
        "  accuracy {:.2}%, worst {:.2}%",
        100.0 * accuracy,
        100.0 * worst
    );
    assert!(accuracy >= 0.971);
    assert!(worst <= 0.082);
    for table in [&fe, &analytic] {
        // Increasing from A1 to A3 for every target, and from B1 to B3 for every contact.
        for row in table.iter() {
            assert!(row[0] < row[1] && row[1] < row[2]);
        }
        for a in 0..3 {
            let column: Vec<f64> = table.iter().map(|row| row[a]).collect();
            assert!(column[0] < column[1] && column[1] < column[2]);
        }
    }
    Ok(())
}

#[test]
fn a_tip_spring_pushes_a_cantilever_to_where_spring_and_rod_balance_and_never_pulls(
) -> Result<(), FemError> {
    let n = 8;
    let model = rod(n)?;
    let c = LENGTH.powi(3) / (3.0 * model.stiffness().bending);
    let k = 2.0 / c;
    let spring = |a: f64| BeamLoads {
        springs: vec![NodeSpring {
            node: n,
            direction: Vector3::new(0.0, 1.0, 0.0),
            anchor: Vector3::new(LENGTH, a, 0.0),
            stiffness: k,
        }],
        ..Default::default()
    };
    // Pressed a = 1e-5 L into the spring: y = c k (a - y), y = a c k / (1 + c k).
    let a = 1e-5 * LENGTH;
    let y = solve(&model, &spring(a), 1)?.nodes_in_world[n].y;
    assert!(rel(y, a * c * k / (1.0 + c * k)) < 1e-4, "tip at {y}");
    // A spring behind the node does nothing.
    let y = solve(&model, &spring(-a), 1)?.nodes_in_world[n].y;
    assert_eq!(y, 0.0);
    Ok(())
}
