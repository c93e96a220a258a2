//! The catheter in its tube ([`softsense::catheter::rig`]) and its scenario file: the
//! tension- and displacement-driven settles agree, contacts satisfy Signorini's law, and
//! the default catheter bends as it was sized to.

use softsense::catheter::coupled::Coupled;
use softsense::catheter::rig::{Drive, SettleParams, SettleStatus};
use softsense::catheter::scenario::Scenario;
use softsense::catheter::tube::Surface;
use softsense::catheter::CatheterError;

const STRAIGHT_TUBE: &str = r#"
[tube]
diameter_mm = 28
pieces = [{ kind = "straight", length_mm = 180 }]
[insertion]
speed_mm_per_s = 1.0
end_mm = 100
"#;

fn scenario(text: &str) -> Scenario {
    Scenario::parse(text, "test.toml").unwrap()
}

#[test]
fn twenty_newtons_on_one_cable_bend_the_default_catheter_ninety_degrees() {
    // The chosen modulus (docs/catheter.md): T r L / EI = 20 N 2.5 mm 166 mm / EI = π/2.
    let s = scenario(STRAIGHT_TUBE);
    let cat = s.catheter(false).unwrap();
    let tube = s.tube().unwrap();
    let t = [20.0, 0.0, 0.0, 0.0];
    let free = cat
        .settle(
            &tube,
            &cat.beam.rest_state(),
            0.0,
            Drive::Tensions(&t),
            &cat.unloaded(),
            &SettleParams::default(),
        )
        .unwrap();
    assert_eq!(free.status, SettleStatus::Settled);
    let q = free.state.world_from_node[cat.tip_node()] * nalgebra::Vector3::x();
    let angle = q.x.clamp(-1.0, 1.0).acos();
    let want = std::f64::consts::FRAC_PI_2;
    assert!((angle - want).abs() < 0.03 * want, "tip turned {angle} rad");
}

#[test]
fn pulling_a_cable_by_its_tension_driven_shortening_gives_back_that_tension() {
    let s = scenario(STRAIGHT_TUBE);
    let cat = s.catheter(true).unwrap();
    let tube = s.tube().unwrap();
    let params = SettleParams::default();
    let start = cat.beam.rest_state();
    let t = [3.0, 0.0, 0.0, 0.0];
    let by_tension = (cat.settle(
        &tube,
        &start,
        0.0,
        Drive::Tensions(&t),
        &cat.unloaded(),
        &params,
    ))
    .unwrap();
    let s0 = cat.shortenings(&by_tension.state);
    // Cable 0 pulled to its shortening plus its own stretch; the others let out 1 mm
    // beyond theirs, so they go slack.
    let pulls: Vec<f64> = (0..4)
        .map(|i| match i {
            0 => s0[0] + cat.cable_compliance * t[0],
            _ => s0[i] - 1e-3,
        })
        .collect();
    let by_pull = (cat.settle(
        &tube,
        &start,
        0.0,
        Drive::Pulls(&pulls),
        &cat.unloaded(),
        &params,
    ))
    .unwrap();
    assert_eq!(by_pull.status, SettleStatus::Settled);
    assert!(
        (by_pull.tensions[0] - 3.0).abs() < 1e-4,
        "{:?}",
        by_pull.tensions
    );
    assert!(
        by_pull.tensions[1..].iter().all(|&v| v.abs() < 1e-6),
        "{:?}",
        by_pull.tensions
    );
    let gap = softsense::math::dist(by_pull.tip(), by_tension.tip());
    assert!(gap < 1e-7, "tips {gap} m apart");
}

#[test]
fn a_catheter_bent_into_the_wall_meets_signorinis_law_at_every_node() {
    // A narrow straight tube: a 4 N pull bends the inserted catheter into its wall.
    let text = STRAIGHT_TUBE.replace("diameter_mm = 28", "diameter_mm = 12");
    let s = scenario(&text);
    let cat = s.catheter(false).unwrap();
    let tube = s.tube().unwrap();
    let t = [4.0, 0.0, 0.0, 0.0];
    let params = SettleParams::default();
    let r = (cat.settle(
        &tube,
        &cat.beam.rest_state(),
        0.1,
        Drive::Tensions(&t),
        &cat.unloaded(),
        &params,
    ))
    .unwrap();
    assert_eq!(r.status, SettleStatus::Settled, "after {} rounds", r.rounds);
    assert!(!r.contacts.is_empty(), "the wall is not reached");
    for c in &r.contacts {
        assert!(c.force > 0.0 && c.gap.abs() < 1e-6, "{c:?}");
    }
    let x = softsense::catheter::rig::Catheter::positions(&r.state);
    for (node, p) in x.iter().enumerate() {
        let g = tube.gap(*p, cat.radius);
        if g.s > 0.0 && g.s < tube.centreline.length() {
            assert!(g.gap > -1e-6, "node {node} is {} m into the wall", -g.gap);
        }
    }
}

#[test]
fn a_point_obstacle_props_the_slack_catheter_with_the_cantilever_force_3_ei_delta_over_a_cubed() {
    // Inserted 66.4 mm, node 8 of 10 is at x = 33.2 mm, a = 132.8 mm from the clamped base.
    // A 1 mm post whose surface is 1 mm above the catheter's lifts that node by δ = 1 mm;
    // the rest of the catheter is free, so the post carries 3 EI δ / a³ (small deflection:
    // δ / a = 0.75%).
    let text = format!("{STRAIGHT_TUBE}\n[[obstacle]]\nat_mm = [33.2, -3.5, 0]\nradius_mm = 1\n");
    let s = scenario(&text);
    let cat = s.catheter(false).unwrap();
    let tube = s.tube().unwrap();
    let r = (cat.settle(
        &tube,
        &cat.beam.rest_state(),
        0.0664,
        Drive::Tensions(&[0.0; 4]),
        &cat.unloaded(),
        &SettleParams::default(),
    ))
    .unwrap();
    assert_eq!(r.status, SettleStatus::Settled, "after {} rounds", r.rounds);
    assert_eq!(r.contacts.len(), 1, "{:?}", r.contacts);
    let c = r.contacts[0];
    assert_eq!((c.node, c.surface), (8, Surface::Obstacle(0)), "{c:?}");
    assert!(c.gap.abs() < 1e-7, "{c:?}");
    let ei = 44.8e6 * std::f64::consts::PI * 3.5e-3_f64.powi(4) / 4.0;
    let want = 3.0 * ei * 1e-3 / 0.1328_f64.powi(3);
    println!(
        "post force {:.6} N, cantilever {want:.6} N ({:+.3}%)",
        c.force,
        100.0 * (c.force / want - 1.0)
    );
    assert!(
        (c.force - want).abs() < 0.01 * want,
        "post force {} N, cantilever {want} N",
        c.force
    );
    assert!(c.normal[1] > 0.999, "pushed along {:?}", c.normal);
}

#[test]
fn scenario_fields_out_of_range_are_refused_by_name() {
    let cases = [
        (
            STRAIGHT_TUBE.replace("end_mm = 100", "end_mm = 190"),
            "insertion.end_mm",
        ),
        (
            STRAIGHT_TUBE.replace("diameter_mm = 28", "diameter_mm = 5"),
            "tube.diameter_mm",
        ),
        (
            STRAIGHT_TUBE.replace("speed_mm_per_s = 1.0", "speed_mm_per_s = -1"),
            "insertion.speed_mm_per_s",
        ),
        (
            format!("{STRAIGHT_TUBE}\n[catheter]\ncable_offset_mm = 4\n"),
            "catheter.cable_offset_mm",
        ),
        (
            format!("{STRAIGHT_TUBE}\n[[obstacle]]\nat_mm = [30, 0, 0]\nradius_mm = -1\n"),
            "obstacle.radius_mm",
        ),
        (
            format!("{STRAIGHT_TUBE}\n[tube.soft]\npoisson = 0.5\n"),
            "tube.soft.poisson",
        ),
        (
            (STRAIGHT_TUBE.replace(
                r#"pieces = [{ kind = "straight", length_mm = 180 }]"#,
                r#"pieces = [{ kind = "arc", radius_mm = 16, angle_deg = 90 }, { kind = "straight", length_mm = 180 }]"#,
            )) + "\n[tube.soft]\nthickness_mm = 3\n",
            "tube.soft.thickness_mm",
        ),
    ];
    for (text, field) in cases {
        match Scenario::parse(&text, "bad.toml") {
            Err(CatheterError::Field { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: {other:?}"),
        }
    }
    let typo = format!("{STRAIGHT_TUBE}\n[plant]\nyoung_facter = 1.1\n");
    let err = Scenario::parse(&typo, "typo.toml").unwrap_err().to_string();
    assert!(
        err.contains("typo.toml") && err.contains("young_facter"),
        "{err}"
    );
}

#[test]
fn bm5_the_models_contact_forces_match_a_four_times_finer_truth_within_three_percent() {
    // Three configurations (a straight tube of 12 or 14 mm, one cable pulled by 4-12 N,
    // inserted 100-140 mm): the 10-element model and a 40-element truth under the same
    // tensions. Issue 55's line: every truth force of 0.1 N or more within 3%, at a model
    // contact within one model element.
    let cases = [(12.0, 4.0, 0.10), (12.0, 8.0, 0.10), (14.0, 12.0, 0.14)];
    let mut compared = 0;
    for (tube_mm, tension, insertion) in cases {
        let text = STRAIGHT_TUBE.replace("diameter_mm = 28", &format!("diameter_mm = {tube_mm}"));
        let settle = |elements: usize| {
            let text = format!("{text}\n[catheter]\nelements = {elements}\n");
            let s = scenario(&text);
            let (cat, tube) = (s.catheter(false).unwrap(), s.tube().unwrap());
            let t = [tension, 0.0, 0.0, 0.0];
            let r = cat
                .settle(
                    &tube,
                    &cat.beam.rest_state(),
                    insertion,
                    Drive::Tensions(&t),
                    &cat.unloaded(),
                    &SettleParams::default(),
                )
                .unwrap();
            assert_eq!(
                r.status,
                SettleStatus::Settled,
                "{tube_mm} mm, {tension} N, {elements} elements"
            );
            r
        };
        let (model, truth) = (settle(10), settle(40));
        let element = 0.166 / 10.0;
        for c in truth.contacts.iter().filter(|c| c.force >= 0.1) {
            let m = (model.contacts.iter())
                .find(|m| (m.s - c.s).abs() <= element)
                .unwrap_or_else(|| {
                    panic!("no model contact near s = {} m: {:?}", c.s, model.contacts)
                });
            let error = (m.force - c.force).abs() / c.force;
            println!(
                "{tube_mm} mm tube, {tension} N: truth {:.4} N at {:.1} mm, model {:.4} N ({:.2}%)",
                c.force,
                1e3 * c.s,
                m.force,
                100.0 * error
            );
            assert!(error <= 0.03, "{error}");
            compared += 1;
        }
    }
    assert!(compared >= 2, "only {compared} forces of 0.1 N or more");
}

#[test]
fn the_free_models_insertion_column_is_the_insertion_axis_as_central_differences_say() {
    // Coupled::model_jacobian takes Ĵ's insertion column from the insertion's axis instead
    // of two settles; here both ways, about a catheter bent by uneven pulls at 40 mm.
    let s = scenario(STRAIGHT_TUBE);
    let coupled = Coupled::new(&s).unwrap();
    let inputs = [0.04, 3e-4, -1e-4];
    let rest = s.catheter(false).unwrap().unloaded();
    let at = coupled.settle_free(&rest, &inputs).unwrap();
    assert_eq!(at.status, SettleStatus::Settled);
    let derived = coupled.model_jacobian(&at, &inputs).unwrap().unwrap();
    let central = (coupled.model_jacobian_by_differences(&at, &inputs))
        .unwrap()
        .unwrap();
    let off = (derived.column(0) - central.column(0)).norm() / central.column(0).norm();
    println!(
        "insertion column {:?}, relative difference {off:.1e}",
        central.column(0)
    );
    assert!(off < 1e-9, "derived {derived}, central {central}");
    // The pulls' columns are the same differences in both.
    assert_eq!(derived.columns(1, 2), central.columns(1, 2));
    // The pulls bend the catheter, so its tip is off the axis the column points along.
    assert!(at.tip()[1].abs() > 1e-3, "tip {:?}", at.tip());
}
