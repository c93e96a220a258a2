//! Generates the project's own demo RGB-D frame and cloud, deterministically:
//!
//! - `tests/fixtures/rgbd/depth.png` (16-bit, millimetres, 0 = no return),
//!   `tests/fixtures/rgbd/color.png` (8-bit RGB), `tests/fixtures/rgbd/intrinsics.json`
//!   (Open3D `PinholeCameraIntrinsic`);
//! - `clouds/demo_scene.pcd`: those images converted by `softsense::io::rgbd::read_frame`
//!   and written `binary_compressed`.
//!
//! The scene, ray-cast from a 320x240 camera 0.55 m above a table and pitched 45° down:
//! a table top (a wood-coloured checkerboard, 5 cm squares), a blue box, and an orange
//! upright "soft finger" (a cylinder with a hemispherical tip). Rays that miss everything
//! have no depth. Run from the repository root:
//!
//! ```text
//! cargo run --release --example make_demo_cloud
//! ```

use softsense::io::intrinsics::{read_camera_model, PinholeIntrinsics};
use softsense::io::{rgbd, write_cloud, Encoding};
use std::error::Error;
use std::path::Path;

type V3 = [f64; 3];

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / dot(a, a).sqrt())
}

/// A ray hit: distance along the ray, world normal, base colour.
struct Hit {
    t: f64,
    normal: V3,
    color: [f64; 3],
}

const TABLE: ([f64; 2], [f64; 2]) = ([-0.40, 0.40], [-0.10, 0.60]);
const BOX_LO: V3 = [0.08, 0.15, 0.0];
const BOX_HI: V3 = [0.22, 0.30, 0.12];
const FINGER: (f64, f64, f64, f64) = (-0.12, 0.20, 0.035, 0.20); // x, y, radius, height

fn hit_table(o: V3, d: V3) -> Option<Hit> {
    if d[2] >= 0.0 {
        return None;
    }
    let t = -o[2] / d[2];
    let p = add(o, scale(d, t));
    let ((x0, x1), (y0, y1)) = ((TABLE.0[0], TABLE.0[1]), (TABLE.1[0], TABLE.1[1]));
    if p[0] < x0 || p[0] > x1 || p[1] < y0 || p[1] > y1 {
        return None;
    }
    let square = ((p[0] / 0.05).floor() + (p[1] / 0.05).floor()) as i64;
    let color = if square.rem_euclid(2) == 0 {
        [205.0, 170.0, 120.0]
    } else {
        [175.0, 140.0, 95.0]
    };
    Some(Hit {
        t,
        normal: [0.0, 0.0, 1.0],
        color,
    })
}

fn hit_box(o: V3, d: V3) -> Option<Hit> {
    let (mut t0, mut t1, mut axis) = (f64::NEG_INFINITY, f64::INFINITY, 0);
    for a in 0..3 {
        if d[a].abs() < 1e-12 {
            if o[a] < BOX_LO[a] || o[a] > BOX_HI[a] {
                return None;
            }
            continue;
        }
        let (mut ta, mut tb) = ((BOX_LO[a] - o[a]) / d[a], (BOX_HI[a] - o[a]) / d[a]);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        if ta > t0 {
            t0 = ta;
            axis = a;
        }
        t1 = t1.min(tb);
    }
    if t0 > t1 || t0 <= 0.0 {
        return None;
    }
    let mut normal = [0.0; 3];
    normal[axis] = -d[axis].signum();
    Some(Hit {
        t: t0,
        normal,
        color: [40.0, 90.0, 200.0],
    })
}

fn hit_finger(o: V3, d: V3) -> Option<Hit> {
    let (cx, cy, r, h) = FINGER;
    let orange = [240.0, 120.0, 30.0];
    let mut best: Option<Hit> = None;
    // Side: (x-cx)² + (y-cy)² = r², 0 <= z <= h - r.
    let (ox, oy) = (o[0] - cx, o[1] - cy);
    let a = d[0] * d[0] + d[1] * d[1];
    let b = 2.0 * (ox * d[0] + oy * d[1]);
    let c = ox * ox + oy * oy - r * r;
    let disc = b * b - 4.0 * a * c;
    if a > 1e-12 && disc >= 0.0 {
        let t = (-b - disc.sqrt()) / (2.0 * a);
        let p = add(o, scale(d, t));
        if t > 0.0 && p[2] >= 0.0 && p[2] <= h - r {
            best = Some(Hit {
                t,
                normal: normalize([p[0] - cx, p[1] - cy, 0.0]),
                color: orange,
            });
        }
    }
    // Tip: sphere of radius r centred on the axis at z = h - r, upper half.
    let centre = [cx, cy, h - r];
    let oc = [o[0] - centre[0], o[1] - centre[1], o[2] - centre[2]];
    let (b, c) = (2.0 * dot(oc, d), dot(oc, oc) - r * r);
    let disc = b * b - 4.0 * dot(d, d) * c;
    if disc >= 0.0 {
        let t = (-b - disc.sqrt()) / (2.0 * dot(d, d));
        let p = add(o, scale(d, t));
        if t > 0.0 && p[2] >= h - r && best.as_ref().is_none_or(|h| t < h.t) {
            best = Some(Hit {
                t,
                normal: normalize([p[0] - cx, p[1] - cy, p[2] - (h - r)]),
                color: orange,
            });
        }
    }
    best
}

/// Renders raw depth (mm) and colour for the demo scene.
fn render(k: &PinholeIntrinsics) -> (Vec<u16>, Vec<[u8; 3]>) {
    let pitch = 45f64.to_radians();
    let camera = [0.0, -0.45, 0.55];
    let right = [1.0, 0.0, 0.0];
    let down = [0.0, -pitch.sin(), -pitch.cos()];
    let forward = [0.0, pitch.cos(), -pitch.sin()];
    let light = normalize([0.3, -0.5, 1.0]);
    let mut depth = Vec::new();
    let mut color = Vec::new();
    for v in 0..k.height {
        for u in 0..k.width {
            let (xc, yc) = ((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy);
            // Ray with unit z in the camera frame, so the hit parameter t is the depth.
            let dir = add(add(scale(right, xc), scale(down, yc)), forward);
            let hit = [hit_table, hit_box, hit_finger]
                .iter()
                .filter_map(|f| f(camera, dir))
                .min_by(|a, b| a.t.total_cmp(&b.t));
            match hit {
                Some(h) => {
                    let shade = 0.45 + 0.55 * dot(h.normal, light).max(0.0);
                    depth.push((h.t * 1000.0).round().min(65535.0) as u16);
                    color.push(h.color.map(|c| (c * shade).round().clamp(0.0, 255.0) as u8));
                }
                None => {
                    depth.push(0);
                    color.push([40, 40, 48]);
                }
            }
        }
    }
    (depth, color)
}

fn main() -> Result<(), Box<dyn Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let fixtures = root.join("tests/fixtures/rgbd");
    std::fs::create_dir_all(&fixtures)?;
    std::fs::create_dir_all(root.join("clouds"))?;
    let k = PinholeIntrinsics {
        width: 320,
        height: 240,
        fx: 262.5,
        fy: 262.5,
        cx: 159.5,
        cy: 119.5,
    };
    let (depth, color) = render(&k);
    let (w, h) = (k.width, k.height);
    let depth_img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, depth)
        .ok_or("depth buffer size")?;
    depth_img.save(fixtures.join("depth.png"))?;
    let flat: Vec<u8> = color.iter().flatten().copied().collect();
    let color_img =
        image::ImageBuffer::<image::Rgb<u8>, _>::from_raw(w, h, flat).ok_or("colour size")?;
    color_img.save(fixtures.join("color.png"))?;
    let json = serde_json::json!({
        "width": w,
        "height": h,
        "intrinsic_matrix": [k.fx, 0.0, 0.0, 0.0, k.fy, 0.0, k.cx, k.cy, 1.0],
    });
    std::fs::write(
        fixtures.join("intrinsics.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    // Convert through the same path the CLI uses, from the files just written.
    let camera = read_camera_model(fixtures.join("intrinsics.json"))?;
    let cloud = rgbd::read_frame(
        fixtures.join("depth.png"),
        Some(fixtures.join("color.png").as_path()),
        &camera,
    )?;
    let out = root.join("clouds/demo_scene.pcd");
    write_cloud(&out, &cloud, Encoding::BinaryCompressed)?;
    eprintln!(
        "wrote {} ({} points, {} finite) and tests/fixtures/rgbd/{{depth,color}}.png, intrinsics.json",
        out.display(),
        cloud.len(),
        cloud.count_finite()
    );
    Ok(())
}
