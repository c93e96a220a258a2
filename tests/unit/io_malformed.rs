//! Bad input: the committed malformed corpus (tests/fixtures/malformed, made by its
//! generate.py) and random bytes / mutations fed to every parser. Each must give a typed
//! error, never panic, and never allocate more than the file's size justifies.

use proptest::prelude::*;
use softsense::cloud::PointCloud;
use softsense::io::{pcd, ply, read_cloud, xyz, Encoding, IoError};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// Counts, per thread, the largest single allocation request.
struct PeakAlloc;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator; only records the requested size.
unsafe impl GlobalAlloc for PeakAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = LARGEST.try_with(|m| m.set(m.get().max(layout.size())));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = LARGEST.try_with(|m| m.set(m.get().max(new_size)));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: PeakAlloc = PeakAlloc;

/// Runs `f` and returns its result with the largest single allocation it made.
fn largest_allocation<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST.with(|m| m.set(0));
    let out = f();
    (out, LARGEST.with(Cell::get))
}

/// The error variant's Debug text (`Truncated { .. }`, `Lzf(Short { .. })`).
fn source_debug(e: &IoError) -> String {
    match e {
        IoError::Pcd { source, .. } => format!("{source:?}"),
        IoError::Ply { source, .. } => format!("{source:?}"),
        IoError::Xyz { source, .. } => format!("{source:?}"),
        other => format!("{other:?}"),
    }
}

#[test]
fn every_malformed_file_gives_its_typed_error_without_oversized_allocation() {
    let dir = crate::common::project_root().join("tests/fixtures/malformed");
    let manifest = std::fs::read_to_string(dir.join("EXPECTED.txt")).expect("EXPECTED.txt");
    let mut listed = Vec::new();
    for line in manifest
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
    {
        let (name, variant) = line.split_once(' ').expect("`file variant` lines");
        listed.push(name.to_string());
        let path = dir.join(name);
        let size = std::fs::metadata(&path).expect("corpus file").len() as usize;
        let (result, largest) = largest_allocation(|| read_cloud(&path));
        let err = match result {
            Ok(c) => panic!("{name}: expected {variant}, but read {} points", c.len()),
            Err(e) => e,
        };
        let debug = source_debug(&err);
        assert!(
            debug.starts_with(variant),
            "{name}: expected {variant}, got {debug}"
        );
        let message = err.to_string();
        assert!(
            message.contains(name),
            "{name}: message does not name the file: {message}"
        );
        // The tracker sees read_cloud's buffer for the file itself (it works), and parsing
        // adds only small buffers on top of it.
        assert!(
            largest >= size,
            "{name}: allocation tracker missed the file buffer"
        );
        assert!(
            largest <= 4 * size + 4096,
            "{name}: largest allocation {largest} bytes for a {size}-byte file"
        );
    }
    assert!(listed.len() >= 30, "corpus has only {} files", listed.len());
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap())
        // Sub-folders hold the per-format corpus of tests/integration/malformed_corpus.rs.
        .filter(|e| e.file_type().unwrap().is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != "EXPECTED.txt" && n != "generate.py")
        .collect();
    on_disk.sort();
    listed.sort();
    assert_eq!(
        on_disk, listed,
        "every corpus file is listed in EXPECTED.txt"
    );
}

/// A valid file of every kind and encoding, small enough to mutate byte by byte.
fn valid_files() -> Vec<Vec<u8>> {
    let mut c = PointCloud::from_positions(
        (0..12)
            .map(|i| {
                [
                    i as f32 * 0.1,
                    if i == 5 { f32::NAN } else { 1.0 },
                    -(i as f32),
                ]
            })
            .collect(),
    );
    c.width = 4;
    c.height = 3;
    c.colors = Some((0..12u8).map(|i| [i, 2 * i, 3 * i]).collect());
    c.alpha = Some(vec![255; 12]);
    c.normals = Some(vec![[0.0, 0.0, 1.0]; 12]);
    c.labels = Some((0..12).collect());
    let mut files = Vec::new();
    for enc in [
        Encoding::Ascii,
        Encoding::Binary,
        Encoding::BinaryCompressed,
    ] {
        files.push(pcd::to_pcd_bytes(&c, enc));
    }
    for f in [
        ply::PlyFormat::Ascii,
        ply::PlyFormat::BinaryLittleEndian,
        ply::PlyFormat::BinaryBigEndian,
    ] {
        files.push(ply::to_ply_bytes_with(&c, f));
    }
    files.push(xyz::to_xyz_bytes(&c));
    files
}

/// Feeds bytes to every parser; returns nothing, the test is that none panics and
/// none allocates beyond a multiple of the input.
fn parse_all(bytes: &[u8]) {
    let (_, largest) = largest_allocation(|| {
        let _ = pcd::parse_pcd(bytes);
        let _ = ply::parse_ply(bytes);
        let _ = xyz::parse_xyz(bytes);
    });
    assert!(
        largest <= 16 * bytes.len() + 65_536,
        "allocated {largest} bytes for {} input bytes",
        bytes.len()
    );
}

#[test]
fn valid_files_parse() {
    for (k, f) in valid_files().iter().enumerate() {
        let ok = match k {
            0..=2 => pcd::parse_pcd(f)
                .map(|c| c.len())
                .map_err(|e| e.to_string()),
            3..=5 => ply::parse_ply(f)
                .map(|c| c.len())
                .map_err(|e| e.to_string()),
            _ => xyz::parse_xyz(f)
                .map(|c| c.len())
                .map_err(|e| e.to_string()),
        };
        assert_eq!(ok, Ok(12), "file {k}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_bytes_never_panic_any_parser(bytes in prop::collection::vec(any::<u8>(), 0..2048)) {
        parse_all(&bytes);
    }

    #[test]
    fn random_bytes_after_a_valid_header_never_panic(which in 0usize..7, tail in prop::collection::vec(any::<u8>(), 0..512)) {
        let file = &valid_files()[which];
        let cut = file.windows(11).position(|w| w.starts_with(b"end_header\n") || w.starts_with(b"DATA ")).unwrap_or(0);
        let mut bytes = file[..cut.min(file.len())].to_vec();
        bytes.extend(b"DATA binary_compressed\n");
        bytes.extend(tail);
        parse_all(&bytes);
    }

    #[test]
    fn single_byte_mutations_of_valid_files_never_panic(which in 0usize..7, at in any::<prop::sample::Index>(), byte in any::<u8>()) {
        let mut file = valid_files()[which].clone();
        let i = at.index(file.len());
        file[i] = byte;
        parse_all(&file);
    }

    #[test]
    fn truncations_of_valid_files_never_panic_and_mostly_fail(which in 0usize..7, at in any::<prop::sample::Index>()) {
        let file = &valid_files()[which];
        let cut = at.index(file.len());
        parse_all(&file[..cut]);
        if which < 6 {
            // Binary and PCD bodies cannot lose bytes and still be whole clouds of 12 points.
            let n = match which {
                0..=2 => pcd::parse_pcd(&file[..cut]).map(|c| c.len()).unwrap_or(0),
                _ => ply::parse_ply(&file[..cut]).map(|c| c.len()).unwrap_or(0),
            };
            let text_tail_trim = (which == 0 || which == 3) && file[cut..].iter().all(|b| b.is_ascii_whitespace() || b.is_ascii_digit());
            prop_assert!(n != 12 || text_tail_trim, "truncation at {} of file {} still gave 12 points", cut, which);
        }
    }
}
