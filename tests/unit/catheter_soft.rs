//! The soft tube ([`softsense::catheter::soft_wall`]): its wall's compliance against Lamé's
//! thick cylinder, and a settle against it that shares the interference between the
//! catheter's compliance and the wall's.

use softsense::catheter::rig::{Catheter, Drive, SettleParams, SettleStatus};
use softsense::catheter::scenario::Scenario;
use softsense::catheter::soft_wall::{SoftWall, SoftWallParams};
use softsense::catheter::tube::{Centreline, NodeContact, Piece, Surface, Tube};
use softsense::fem::beam::BeamRow;

/// Radial dent of the inner surface of a long tube (inner radius a, outer b held) under a
/// uniform internal pressure p, in plane strain (Lamé): u = A r + B / r, u(b) = 0,
/// σ_r(a) = −p.
fn lame_dent(p: f64, a: f64, b: f64, e: f64, nu: f64) -> f64 {
    let e_plane = e / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let big_b = p / (e_plane * (1.0 / (b * b) + (1.0 - 2.0 * nu) / (a * a)));
    big_b * (1.0 / a - a / (b * b))
}

/// The FE dent at the middle ring of a straight soft tube under internal pressure `p`,
/// from the wall's inner-surface compliance and the nodes' tributary forces.
fn fe_dent(params: &SoftWallParams, a: f64, length: f64, p: f64) -> f64 {
    let c = Centreline::from_pieces(
        [0.0; 3],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        &[Piece::Straight { length }],
        1e-3,
    )
    .unwrap();
    let wall = SoftWall::new(&c, a, params).unwrap();
    let x = &wall.mesh().nodes_in_rest;
    let inner: Vec<usize> = (0..x.len())
        .filter(|&v| ((x[v][1].powi(2) + x[v][2].powi(2)).sqrt() - a).abs() < 1e-9)
        .collect();
    let rings = inner.len() / params.around;
    let ds = length / (rings - 1) as f64;
    let points: Vec<([f64; 3], f64)> = inner.iter().map(|&v| (x[v], x[v][0])).collect();
    let w = wall.compliance(&points);
    let arc = 2.0 * std::f64::consts::PI * a / params.around as f64;
    let force: Vec<f64> = (points.iter())
        .map(|(q, _)| {
            let end = q[0] < 1e-9 || q[0] > length - 1e-9;
            p * arc * ds * if end { 0.5 } else { 1.0 }
        })
        .collect();
    let middle = (0..points.len())
        .min_by(|&i, &j| {
            let d = |k: usize| (points[k].0[0] - 0.5 * length).abs();
            d(i).total_cmp(&d(j))
        })
        .unwrap();
    (0..points.len()).map(|j| w[(middle, j)] * force[j]).sum()
}

#[test]
fn a_soft_wall_under_internal_pressure_dents_as_lames_thick_cylinder() {
    // a = 14 mm (the thesis's tube), b = 17 mm held, 60 mm long: its middle is in plane
    // strain. A fine wall at ν = 0.3, and the default one (ν = 0.45, 2 layers, 24 cells
    // round), where linear tetrahedra could lock.
    let (a, length, p) = (14e-3, 60e-3, 1e3);
    let fine = SoftWallParams {
        poisson: 0.3,
        around: 48,
        layers: 4,
        ring_step: 1.5e-3,
        ..SoftWallParams::default()
    };
    let want = lame_dent(p, a, a + fine.thickness, fine.young_modulus, 0.3);
    let got = fe_dent(&fine, a, length, p);
    let coarse = SoftWallParams::default();
    let want_default = lame_dent(p, a, a + 3e-3, coarse.young_modulus, coarse.poisson);
    let got_default = fe_dent(&coarse, a, length, p);
    println!(
        "dent under 1 kPa: fine wall {:.4} µm against Lamé {:.4} µm ({:+.2}%); default wall \
         {:.4} µm against {:.4} µm ({:+.2}%)",
        1e6 * got,
        1e6 * want,
        100.0 * (got / want - 1.0),
        1e6 * got_default,
        1e6 * want_default,
        100.0 * (got_default / want_default - 1.0)
    );
    assert!((got - want).abs() < 0.05 * want, "{got} m against {want} m");
    let off = (got_default - want_default).abs();
    assert!(
        off < 0.05 * want_default,
        "{got_default} m against {want_default} m"
    );
}

#[test]
fn a_tip_pressed_into_a_soft_wall_shares_the_interference_between_both_compliances() {
    // A 60 mm catheter inserted 30 mm along +x; the tube's axis is tilted by asin 0.2 so that
    // its wall cuts 0.5 mm into the tip's section and stays clear of the other nodes. The
    // push F closes the interference δ through the catheter's compliance along the normal
    // and the wall's at the contact: F = δ / (W_beam + C_wall). A rigid wall would give
    // δ / W_beam.
    let text = r#"
[tube]
diameter_mm = 28
pieces = [{ kind = "straight", length_mm = 250 }]
[catheter]
length_mm = 60
[insertion]
speed_mm_per_s = 1.0
end_mm = 30
"#;
    let s = Scenario::parse(text, "test.toml").unwrap();
    let cat = s.catheter(false).unwrap();
    let (sin, delta) = (0.2_f64, 0.5e-3);
    let cos = (1.0 - sin * sin).sqrt();
    let tip = [0.030, 0.0, 0.0];
    // Axis through q, at distance 14 - 3.5 + δ mm from the tip.
    let d = 14e-3 - 3.5e-3 + delta;
    let q = [tip[0], d / cos, 0.0];
    let start = [q[0] - 0.15 * cos, q[1] - 0.15 * sin, 0.0];
    let pieces = [Piece::Straight { length: 0.25 }];
    let c = Centreline::from_pieces(start, [cos, sin, 0.0], [0.0, 0.0, 1.0], &pieces, 1e-3);
    let c = c.unwrap();
    let tube = Tube::new(c.clone(), 14e-3).unwrap();
    // A gel-soft wall (10 kPa), so that its compliance is a good part of the catheter's.
    let gel = SoftWallParams {
        young_modulus: 10e3,
        ..SoftWallParams::default()
    };
    let soft = (tube.clone().with_soft_wall(&gel)).unwrap();
    let settle = |tube: &Tube| {
        cat.settle(
            tube,
            &cat.beam.rest_state(),
            0.030,
            Drive::Tensions(&[0.0; 4]),
            &cat.unloaded(),
            &SettleParams::default(),
        )
        .unwrap()
    };
    let (rigid_r, soft_r) = (settle(&tube), settle(&soft));
    for r in [&rigid_r, &soft_r] {
        assert_eq!(r.status, SettleStatus::Settled, "after {} rounds", r.rounds);
        assert_eq!(r.contacts.len(), 1, "{:?}", r.contacts);
        assert_eq!(
            (r.contacts[0].node, r.contacts[0].surface),
            (10, Surface::Wall)
        );
        assert!(r.contacts[0].gap.abs() < 1e-8, "{:?}", r.contacts[0]);
    }
    // Both compliances at the inserted, untouched catheter (a tube too wide to touch),
    // along the contact's normal there.
    let free = settle(&Tube::new(c, 1.0).unwrap());
    assert!(free.contacts.is_empty());
    let x = Catheter::positions(&free.state);
    let row = NodeContact {
        node: 10,
        ..tube.gap_to(Surface::Wall, x[10], cat.radius)
    };
    assert!(
        (row.gap + delta).abs() < 1e-9,
        "interference {} m",
        -row.gap
    );
    let w_beam = (cat.beam.linearise_loaded(&free.state, &[]).unwrap())
        .compliance(&[BeamRow::translation(10, row.normal)])[(0, 0)];
    let c_wall = soft.wall_compliance(&[row], &x, cat.radius).unwrap()[(0, 0)];
    let (want_rigid, want_soft) = (delta / w_beam, delta / (w_beam + c_wall));
    let (f_rigid, f_soft) = (rigid_r.contacts[0].force, soft_r.contacts[0].force);
    println!(
        "W_beam {w_beam:.5} m/N, C_wall {c_wall:.5} m/N; rigid {:.4} mN against {:.4} mN \
         ({:+.2}%), soft {:.4} mN against {:.4} mN ({:+.2}%)",
        1e3 * f_rigid,
        1e3 * want_rigid,
        100.0 * (f_rigid / want_rigid - 1.0),
        1e3 * f_soft,
        1e3 * want_soft,
        100.0 * (f_soft / want_soft - 1.0)
    );
    assert!(
        c_wall > 0.1 * w_beam,
        "the wall must matter here: {c_wall} against {w_beam}"
    );
    assert!((f_rigid - want_rigid).abs() < 0.02 * want_rigid);
    assert!((f_soft - want_soft).abs() < 0.02 * want_soft);
}
