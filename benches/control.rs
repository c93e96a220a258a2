//! One control step on the four-legged robot (issue: within 33 ms on one core): the
//! controller's FE model driven to new inputs (a warm Newton solve), J from the effector
//! and cable compliance there, and the input allocation. Run on one core with
//! `RAYON_NUM_THREADS=1 taskset -c 0 cargo bench --bench control`.

use criterion::{criterion_group, criterion_main, Criterion};
use softsense::control::predictor::Predictor;
use softsense::control::scenario::Actuation;
use softsense::fem::model::Model;
use std::path::PathBuf;

fn control_step(c: &mut Criterion) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).expect("robot model");
    let mut p = Predictor::new(model, None, Actuation::Displacement).expect("predictor");
    let base = vec![0.010; 4];
    p.update(&base).expect("first state");
    let mut k = 0usize;
    c.bench_function("control_step/robot", |b| {
        b.iter(|| {
            // A circle-like input change of 0.1 mm per step, as a tracking step makes.
            k += 1;
            let a = 0.1 * k as f64;
            let inputs: Vec<f64> = (0..4)
                .map(|i| base[i] + 1e-4 * (a + i as f64 * std::f64::consts::FRAC_PI_2).sin())
                .collect();
            let kin = p.update(&inputs).expect("update");
            kin.allocate([1e-4, -1e-4, 0.0], &inputs, [0.0, 0.04])
                .expect("allocate")
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = control_step
}
criterion_main!(benches);
