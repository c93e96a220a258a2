//! Mutation fuzzing: valid files of every parser (the corpus seeds of
//! tools/make_malformed_corpus.py and small bundled files) with seeded random bit flips,
//! truncations, insertions, overwrites and duplications, at least 1,000 cases per parser.
//! Errors are fine; a panic is not. Every panic is collected and reported at once.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Cases per parser.
pub(crate) const CASES: usize = 1000;

/// splitmix64: a tiny seeded generator, so a failing case can be replayed by its number.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One to three random edits of `valid`.
pub(crate) fn mutate(valid: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = valid.to_vec();
    for _ in 0..1 + rng.below(3) {
        let n = b.len();
        match rng.below(6) {
            0 if n > 0 => {
                let at = rng.below(n);
                b[at] ^= 1 << rng.below(8);
            }
            1 => b.truncate(rng.below(n + 1)),
            2 => {
                let at = rng.below(n + 1);
                let junk: Vec<u8> = (0..1 + rng.below(16)).map(|_| rng.next() as u8).collect();
                b.splice(at..at, junk);
            }
            3 if n > 0 => {
                let at = rng.below(n);
                let fill = [0x00, 0xff, b'9', b'-'][rng.below(4)];
                let end = (at + 1 + rng.below(8)).min(n);
                b[at..end].fill(fill);
            }
            4 if n > 0 => {
                let at = rng.below(n);
                let end = (at + 1 + rng.below(64)).min(n);
                let copy = b[at..end].to_vec();
                b.splice(at..at, copy);
            }
            _ if n > 0 => {
                // A digit becomes another digit or a sign: counts and sizes change.
                let at = rng.below(n);
                if b[at].is_ascii_digit() {
                    b[at] = b"0123456789-."[rng.below(12)];
                }
            }
            _ => {}
        }
    }
    b
}

/// The valid files for a corpus folder: its seed and, where small, bundled files.
fn valid_files(format: &str) -> Vec<PathBuf> {
    let root = crate::common::project_root();
    let dir = root.join("tests/fixtures/malformed").join(format);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_stem().is_some_and(|s| s == "seed"))
        .collect();
    let bundled: &[&str] = match format {
        "depth_png" => &["tests/fixtures/rgbd/depth.png"],
        "color_png" => &["tests/fixtures/rgbd/color.png"],
        "intrinsics_json" => &["tests/fixtures/rgbd/intrinsics.json"],
        "scene_toml" => &[
            "clouds/scenes/probe_side.toml",
            "tests/fixtures/scenes/two_press.toml",
        ],
        _ => &[],
    };
    files.extend(bundled.iter().map(|p| root.join(p)));
    files
}

/// Runs `read` on `CASES` mutations of each of `valid` (written to `work`, named
/// `name`), returning the cases run and a line per panic.
fn fuzz(
    label: &str,
    valid: &[Vec<u8>],
    work: &Path,
    seed: u64,
    read: &dyn Fn(&Path) -> Result<(), String>,
) -> (usize, Vec<String>) {
    let make = |case: usize, rng: &mut Rng| mutate(&valid[case % valid.len()], rng);
    fuzz_with(label, &make, work, seed, read)
}

/// Runs `read` on `CASES` files made by `make(case, rng)` and written to `work`,
/// returning the cases run and a line per panic (each panicking file kept for replay).
pub(crate) fn fuzz_with(
    label: &str,
    make: &dyn Fn(usize, &mut Rng) -> Vec<u8>,
    work: &Path,
    seed: u64,
    read: &dyn Fn(&Path) -> Result<(), String>,
) -> (usize, Vec<String>) {
    let mut rng = Rng(seed);
    let mut panics = Vec::new();
    for case in 0..CASES {
        let bytes = make(case, &mut rng);
        std::fs::write(work, &bytes).unwrap();
        if catch_unwind(AssertUnwindSafe(|| read(work))).is_err() {
            // Kept outside the test's temporary folder, which goes at the end.
            let keep = std::env::temp_dir().join(format!("softsense-fuzz-{label}-{seed}-{case}"));
            let _ = std::fs::write(&keep, &bytes);
            panics.push(format!(
                "{label} case {case} (seed {seed}): kept as {}",
                keep.display()
            ));
        }
    }
    (CASES, panics)
}

#[test]
fn no_parser_panics_on_a_thousand_mutations_of_its_valid_files() {
    let tmp = tempfile::tempdir().unwrap();
    let mut panics = Vec::new();
    let mut counts = Vec::new();
    let started = std::time::Instant::now();
    for (k, format) in crate::common::corpus::FILE_FORMATS.iter().enumerate() {
        let files = valid_files(format);
        assert!(!files.is_empty(), "{format}: no valid file");
        let valid: Vec<Vec<u8>> = files.iter().map(|p| std::fs::read(p).unwrap()).collect();
        // A mutated model still names its mesh beside it; a mutated scene its model.
        let sub = tmp.path().join(format);
        std::fs::create_dir_all(&sub).unwrap();
        if *format == "model_toml" {
            let mesh =
                crate::common::project_root().join("tests/fixtures/malformed/model_toml/tets.vtk");
            std::fs::copy(mesh, sub.join("tets.vtk")).unwrap();
        }
        let ext = files[0].extension().unwrap().to_string_lossy().into_owned();
        let work = sub.join(format!("case.{ext}"));
        let read = |p: &Path| crate::common::corpus::read_as(format, p);
        let (n, p) = fuzz(format, &valid, &work, 7000 + k as u64, &read);
        counts.push(format!("{format} {n}"));
        panics.extend(p);
    }
    // Recording JSON files: each replaces its file in a recording folder that is opened.
    let rec = crate::common::scene_copy(
        "probe_side",
        &[
            "intrinsics.json",
            "camera_pose.json",
            "depth_0000.png",
            "color_0000.png",
            "truth.json",
            "actuators.json",
        ],
    );
    let corpus = crate::common::project_root().join("tests/fixtures/malformed/recording_json");
    for (k, target) in ["camera_pose", "actuators", "inputs", "truth"]
        .iter()
        .enumerate()
    {
        let mut valid = vec![std::fs::read(corpus.join(format!("{target}__seed.json"))).unwrap()];
        if let Ok(bundled) = std::fs::read(rec.path().join(format!("{target}.json"))) {
            valid.push(bundled);
        }
        let work = rec.path().join(format!("{target}.json"));
        let original = std::fs::read(&work).ok();
        let read = |_: &Path| crate::common::corpus::open_recording(rec.path());
        let (n, p) = fuzz(target, &valid, &work, 8000 + k as u64, &read);
        counts.push(format!("{target}.json {n}"));
        panics.extend(p);
        match original {
            Some(b) => std::fs::write(&work, b).unwrap(),
            None => std::fs::remove_file(&work).unwrap(),
        }
    }
    println!(
        "mutation cases: {} in {:.1} s",
        counts.join(", "),
        started.elapsed().as_secs_f64()
    );
    assert!(
        panics.is_empty(),
        "{} panics:\n{}",
        panics.len(),
        panics.join("\n")
    );
}
