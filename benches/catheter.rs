//! One control step of the 166 mm catheter with contacts (issue 55: within 20 ms on one
//! core). The bundled contacts scenario is run to its hold at 88 mm, where the catheter's
//! body lies on the bend's wall, and from there each iteration times, on a copy of that
//! state:
//! - `catheter_step/controller`: the controllers' part (the FE model settled with its
//!   contacts, the FEM controller's QPCC and J, the PD law), which a rig computes per frame;
//! - `catheter_step/loop`: the same plus the simulated robot's own settle.
//!
//! Run on one core with `RAYON_NUM_THREADS=1 taskset -c 0 cargo bench --bench catheter`.
//! Reaching the hold takes about a minute.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use softsense::catheter::run::{Session, Step};
use softsense::catheter::scenario::Scenario;
use std::path::PathBuf;

fn catheter_step(c: &mut Criterion) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let scenario =
        Scenario::load(&root.join("scenarios/catheter/contacts.toml")).expect("contacts scenario");
    let mut session = Session::new(&scenario).expect("session");
    // Into the hold, where the insertion stops and the contacts stay.
    let hold = scenario.steps() - 20;
    while session.steps_taken() < hold {
        match session.step().expect("step") {
            Step::Done(_) => {}
            Step::Failed(reason) => panic!("the contacts scenario failed: {reason}"),
        }
    }
    let (robot, model) = (
        session.robot().contacts.len(),
        session.model().contacts.len(),
    );
    assert!(robot > 0 && model > 0, "the bench state has no contact");
    eprintln!(
        "bench state: step {hold}, contact nodes: {model} on the model, {robot} on the robot"
    );
    let insertion = scenario.insertion_at(hold);
    let measured = session.measured_tip();
    c.bench_function("catheter_step/controller", |b| {
        b.iter_batched_ref(
            || session.clone(),
            |s| s.control(insertion, measured).expect("control"),
            BatchSize::SmallInput,
        )
    });
    c.bench_function("catheter_step/loop", |b| {
        b.iter_batched_ref(
            || session.clone(),
            |s| s.step().expect("step"),
            BatchSize::SmallInput,
        )
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = catheter_step
}
criterion_main!(benches);
