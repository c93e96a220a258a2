//! The opt-in sensor artefacts of `scene::sensor` (docs/sensing.md, "Sensor artefacts
//! fitted on real frames"): each one drawn at its parameter's rate, where it belongs.

use softsense::scene::sensor::SensorModel;

/// A model with nothing random on but what the test turns on: no depth noise, no edge
/// holes, a 10 µm unit fine enough to read the drawn depths back.
fn quiet() -> SensorModel {
    SensorModel {
        depth_k: 0.0,
        depth_unit: 1e-5,
        edge_hole_probability: 0.0,
        ..Default::default()
    }
}

fn metres(d: &[u16], unit: f64) -> Vec<f64> {
    d.iter().map(|&v| v as f64 * unit).collect()
}

fn sd(x: &[f64]) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
}

#[test]
fn random_holes_are_drawn_at_their_probability() {
    let n = 400 * 300;
    let s = SensorModel {
        hole_probability: 0.1,
        ..quiet()
    };
    let d = s.depth(&vec![0.5; n], &vec![1.0; n], 400, 3, 0);
    let share = d.iter().filter(|&&v| v == 0).count() as f64 / n as f64;
    // Binomial σ = sqrt(0.1 · 0.9 / n) = 0.00087; four of them.
    assert!((share - 0.1).abs() < 0.0035, "hole share {share}");
    // Another frame draws other holes.
    let e = s.depth(&vec![0.5; n], &vec![1.0; n], 400, 3, 1);
    assert_ne!(d, e);
}

#[test]
fn flying_pixels_appear_only_at_depth_edges_and_lie_between_the_two_depths() {
    // Left half at 0.4 m, right half at 0.6 m: the edge is columns 99 and 100.
    let (w, h) = (200, 300);
    let z: Vec<f64> = (0..w * h)
        .map(|i| if i % w < 100 { 0.4 } else { 0.6 })
        .collect();
    let s = SensorModel {
        flying_probability: 0.3,
        ..quiet()
    };
    let m = metres(&s.depth(&z, &vec![1.0; w * h], w, 5, 0), 1e-5);
    let mut flew = 0;
    for (i, &v) in m.iter().enumerate() {
        if (v - z[i]).abs() < 1e-9 {
            continue;
        }
        assert!(
            matches!(i % w, 99 | 100),
            "pixel {i} off the edge reads {v}"
        );
        assert!(
            v > 0.4 && v < 0.6,
            "pixel {i} reads {v}, not between the depths"
        );
        flew += 1;
    }
    // 600 edge pixels at 0.3: σ = sqrt(600 · 0.21) = 11 pixels.
    assert!((flew as f64 - 180.0).abs() < 45.0, "{flew} flying pixels");
    // A spread of 0.2 keeps the mixing fraction within 0.4-0.6 of the jump.
    let narrow = SensorModel {
        flying_spread: 0.2,
        flying_probability: 1.0,
        ..quiet()
    };
    let m = metres(&narrow.depth(&z, &vec![1.0; w * h], w, 5, 0), 1e-5);
    for v in m
        .iter()
        .filter(|v| (**v - 0.4).abs() > 1e-9 && (**v - 0.6).abs() > 1e-9)
    {
        assert!((0.48 - 1e-5..=0.52 + 1e-5).contains(v), "{v}");
    }
}

#[test]
fn a_quantisation_step_growing_as_z_squared_puts_depths_on_its_grid() {
    let (w, h) = (100, 100);
    let z: Vec<f64> = (0..w * h)
        .map(|i| 0.6 + 1.0 * i as f64 / (w * h) as f64)
        .collect();
    let s = SensorModel {
        depth_step_k: 0.003,
        depth_unit: 1e-5,
        ..Default::default()
    };
    let m = metres(&s.depth(&z, &vec![1.0; w * h], w, 7, 0), 1e-5);
    for (v, zi) in m.iter().zip(&z) {
        let step = 0.003 * zi * zi;
        let off = (v / step - (v / step).round()).abs() * step;
        assert!(
            off <= 0.5e-5 + 1e-12,
            "{v} is {off} m off the {step} m grid"
        );
    }
}

#[test]
fn the_noise_sigma_matches_floor_plus_k_z2_at_two_depths_and_grows_with_incidence() {
    let n = 40_000;
    let s = SensorModel {
        depth_k: 0.002,
        depth_sigma_floor: 1e-4,
        ..quiet()
    };
    for z in [0.2, 0.6] {
        let m = metres(&s.depth(&vec![z; n], &vec![1.0; n], 200, 9, 0), 1e-5);
        let expected = 1e-4 + 0.002 * z * z;
        let got = sd(&m);
        // σ of a sample σ: 1/sqrt(2n) = 0.35%; the 10 µm unit adds 3 µm in quadrature.
        assert!(
            (got / expected - 1.0).abs() < 0.02,
            "z {z}: {got} vs {expected}"
        );
    }
    // g = 1 at 60° incidence (1/cos θ = 2): twice the σ.
    let g = SensorModel {
        depth_sigma_incidence: 1.0,
        ..s
    };
    let m = metres(&g.depth(&vec![0.5; n], &vec![0.5; n], 200, 9, 0), 1e-5);
    let expected = 2.0 * (1e-4 + 0.002 * 0.25);
    assert!((sd(&m) / expected - 1.0).abs() < 0.02, "{}", sd(&m));
}

#[test]
fn the_default_model_writes_none_of_the_opt_in_fields() {
    // truth.json and sensor.json of existing scenes stay byte for byte as before.
    let v = serde_json::to_value(SensorModel::default()).unwrap();
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(|k| k.as_str()).collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "color_sigma",
            "depth_k",
            "depth_unit",
            "edge_hole_probability",
            "edge_jump",
            "enabled",
            "grazing_deg"
        ]
    );
    let on = SensorModel {
        hole_probability: 0.01,
        flying_spread: 0.2,
        ..Default::default()
    };
    let text = toml::to_string(&on).unwrap();
    let back: SensorModel = toml::from_str(&text).unwrap();
    assert_eq!((back.hole_probability, back.flying_spread), (0.01, 0.2));
}
