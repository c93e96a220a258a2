//! sRGB to CIELAB (D65) and the CIE76 colour difference ΔE.
//!
//! The conversion follows OpenCV's `cvtColor(RGB2Lab)` float path (its constants:
//! sRGB primaries matrix, white point Xn = 0.950456, Zn = 1.088754, threshold 0.008856,
//! L = 903.3·Y below it), computed in `f64`; L in 0..100, a and b about -128..127.
//!
//! ```
//! use softsense::segment::color::{rgb_to_lab, delta_e};
//! let white = rgb_to_lab([255, 255, 255]);
//! assert!((white[0] - 100.0).abs() < 1e-3 && white[1].abs() < 1e-3);
//! assert!(delta_e(rgb_to_lab([255, 0, 0]), rgb_to_lab([0, 0, 255])) > 100.0);
//! ```

/// sRGB gamma expansion of a channel in 0..1.
fn linearize(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn f(t: f64) -> f64 {
    if t > 0.008856 {
        t.cbrt()
    } else {
        7.787 * t + 16.0 / 116.0
    }
}

/// CIELAB of an sRGB colour given as floats in 0..1 (values outside are not clamped).
pub fn rgb_f64_to_lab(rgb: [f64; 3]) -> [f64; 3] {
    linear_to_lab(rgb.map(linearize))
}

/// CIELAB of a linear-light RGB colour.
fn linear_to_lab([r, g, b]: [f64; 3]) -> [f64; 3] {
    let x = (0.412453 * r + 0.357580 * g + 0.180423 * b) / 0.950456;
    let y = 0.212671 * r + 0.715160 * g + 0.072169 * b;
    let z = (0.019334 * r + 0.119193 * g + 0.950227 * b) / 1.088754;
    let (fx, fy, fz) = (f(x), f(y), f(z));
    // Above the threshold f(y) is the cube root of y.
    let l = if y > 0.008856 {
        116.0 * fy - 16.0
    } else {
        903.3 * y
    };
    [l, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// CIELAB of an 8-bit sRGB colour.
pub fn rgb_to_lab(rgb: [u8; 3]) -> [f64; 3] {
    // The gamma expansion of the 256 channel values, computed once: the same numbers as
    // `linearize(c / 255)`, without three `powf` per pixel.
    static LINEAR: std::sync::OnceLock<[f64; 256]> = std::sync::OnceLock::new();
    let table = LINEAR.get_or_init(|| std::array::from_fn(|c| linearize(c as f64 / 255.0)));
    linear_to_lab(rgb.map(|c| table[c as usize]))
}

/// CIELAB of an 8-bit sRGB colour in `f32`.
pub fn rgb_to_lab_f32(rgb: [u8; 3]) -> [f32; 3] {
    rgb_to_lab(rgb).map(|v| v as f32)
}

/// CIE76 colour difference: Euclidean distance in CIELAB.
pub fn delta_e(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
