//! The whole sensing chain per frame (`softsense sense`): read and back-project the 640x480
//! depth + colour PNGs, crop, segment by colour, detect contacts, register the features,
//! map locations, solve the intensity QPs with FE updates. One iteration is one pass over
//! a committed recording's frames with a persistent [`Sensor`] (a stream: the free FE solve
//! is cached after the first pass). Per-stage medians and frames per second next to the
//! thesis's 10 Hz / 7 Hz: `tools/bench/run.sh --only 'sense: whole chain per frame'`. Each
//! scene is also timed as a tracked stream ([`Sensor::track_frames`]).

use criterion::{criterion_group, criterion_main, Criterion};
use softsense::fem::model::Model;
use softsense::sense::{Recording, SenseParams, Sensor};
use std::path::PathBuf;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut g = c.benchmark_group("sense");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(20));
    for scene in ["tip_weight", "probe_side", "two_probes", "probe_press"] {
        let rec = Recording::open(&root.join("clouds/scenes").join(scene)).expect("recording");
        let model = Model::load(&rec.model_path().expect("model path"), None).expect("model");
        let sensor = Sensor::new(
            model,
            rec.robot_from_camera.unwrap(),
            SenseParams::default(),
        );
        let name = format!("{scene} ({} frames)", rec.frames.len());
        g.bench_function(name, |b| {
            b.iter(|| {
                for &frame in &rec.frames {
                    let obs = sensor.observe(&rec, frame).expect("frame");
                    std::hint::black_box(sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref()));
                }
            })
        });
        // As a live stream (`sense --track`): each frame starts from the one before.
        let name = format!("{scene} tracked ({} frames)", rec.frames.len());
        g.bench_function(name, |b| {
            b.iter(|| {
                sensor
                    .track_frames(&rec, &rec.frames, |_, r| {
                        std::hint::black_box(r);
                        Ok::<(), ()>(())
                    })
                    .expect("stream")
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
