//! Shape measures of one tetrahedron that meshers report and limit: dihedral angles and
//! the radius-edge ratio (circumradius over shortest edge), as TetGen and gmsh state them.

use crate::math::{cross, dot, norm, sub};

/// The smallest and largest of a tetrahedron's six dihedral angles (degrees).
pub fn dihedral_range_deg(c: &[[f64; 3]; 4]) -> [f64; 2] {
    let mut range = [f64::INFINITY, f64::NEG_INFINITY];
    for (i, j, k, l) in [
        (0, 1, 2, 3),
        (0, 2, 1, 3),
        (0, 3, 1, 2),
        (1, 2, 0, 3),
        (1, 3, 0, 2),
        (2, 3, 0, 1),
    ] {
        let e = sub(c[j], c[i]);
        let e2 = dot(e, e);
        // The other two corners projected onto the plane normal to the edge: the angle
        // between them is the angle between the two faces that meet at the edge.
        let across = |p: [f64; 3]| {
            let d = sub(p, c[i]);
            let s = dot(d, e) / e2;
            [d[0] - s * e[0], d[1] - s * e[1], d[2] - s * e[2]]
        };
        let (u, w) = (across(c[k]), across(c[l]));
        let angle = norm(cross(u, w)).atan2(dot(u, w)).to_degrees();
        range = [range[0].min(angle), range[1].max(angle)];
    }
    range
}

/// Circumradius over shortest edge (0.612 for a regular tetrahedron; infinite for a flat one).
pub fn radius_edge(c: &[[f64; 3]; 4]) -> f64 {
    let (a, b, d) = (sub(c[1], c[0]), sub(c[2], c[0]), sub(c[3], c[0]));
    let det = 2.0 * dot(a, cross(b, d));
    let terms = [
        (dot(a, a), cross(b, d)),
        (dot(b, b), cross(d, a)),
        (dot(d, d), cross(a, b)),
    ];
    let mut centre = [0.0; 3];
    for (s, v) in terms {
        for k in 0..3 {
            centre[k] += s * v[k] / det;
        }
    }
    let mut shortest = f64::INFINITY;
    for i in 0..4 {
        for j in i + 1..4 {
            shortest = shortest.min(norm(sub(c[i], c[j])));
        }
    }
    norm(centre) / shortest
}

#[cfg(test)]
mod tests {
    use super::*;

    fn regular() -> [[f64; 3]; 4] {
        [
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ]
    }

    #[test]
    fn a_regular_tetrahedron_has_every_dihedral_at_acos_one_third() {
        let [lo, hi] = dihedral_range_deg(&regular());
        let want = (1.0f64 / 3.0).acos().to_degrees();
        assert!(
            (lo - want).abs() < 1e-9 && (hi - want).abs() < 1e-9,
            "{lo} {hi}"
        );
        assert!((radius_edge(&regular()) - 6f64.sqrt() / 4.0).abs() < 1e-12);
    }

    #[test]
    fn the_corner_tetrahedron_has_right_angles_and_a_known_circumradius() {
        let c = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let [lo, hi] = dihedral_range_deg(&c);
        // Three faces meet the origin at right angles; the slanted face meets each at
        // acos(1/sqrt 3) = 54.7 degrees.
        assert!((hi - 90.0).abs() < 1e-9, "{hi}");
        assert!(
            (lo - (1.0 / 3f64.sqrt()).acos().to_degrees()).abs() < 1e-9,
            "{lo}"
        );
        // The circumcentre is (1/2, 1/2, 1/2): R = sqrt(3)/2 over the unit edge.
        assert!((radius_edge(&c) - 3f64.sqrt() / 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_sliver_has_dihedrals_near_zero_and_near_180() {
        let h = 1e-3;
        let c = [
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 0.0, h],
            [0.0, 1.0, h],
        ];
        let [lo, hi] = dihedral_range_deg(&c);
        assert!(lo < 1.0 && hi > 179.0, "{lo} {hi}");
    }
}
