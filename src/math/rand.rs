//! Counter-based random draws: every number is a hash of its key (seed, frame, pixel,
//! stream), so a draw does not depend on thread scheduling or on which draws came before.
//! The scene generator's noise, the control plant's noise and the PSO's particles all draw
//! here.

/// splitmix64 finaliser.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The noise seed of camera `index` of a scene with several cameras and seed `seed`: each
/// camera its own draw, depending only on the two (never on threads or on the other
/// cameras).
pub fn camera_seed(seed: u64, index: usize) -> u64 {
    mix(mix(seed) ^ mix(index as u64 + 1))
}

/// A uniform number in (0, 1) from the key (seed, frame, pixel, stream).
pub fn uniform(seed: u64, frame: u64, pixel: u64, stream: u64) -> f64 {
    let h = mix(mix(mix(mix(seed) ^ frame) ^ pixel) ^ stream);
    ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

/// A standard normal number from the key (Box-Muller on two uniforms).
pub fn normal(seed: u64, frame: u64, pixel: u64, stream: u64) -> f64 {
    let u1 = uniform(seed, frame, pixel, 2 * stream);
    let u2 = uniform(seed, frame, pixel, 2 * stream + 1);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}
