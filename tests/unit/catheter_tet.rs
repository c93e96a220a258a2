//! The beam against the catheter as coarse tetrahedra ([`softsense::catheter::tetra`]);
//! the fine meshes are in the acceptance tier. Linear tetrahedra are too stiff in bending
//! and a conforming mesh is never more compliant than the solid it meshes, so refining
//! must bring W up towards the beam's from below; and once the beam is given the
//! tetrahedra's own bending stiffness, a cable must bend both alike.

use crate::common::catheter_tet::{bends, compliance_ratios};

#[test]
fn refined_tetrahedra_approach_the_beam_compliance_from_the_stiff_side() {
    let ratios = [4usize, 6, 8].map(|n| compliance_ratios(n, 2.0));
    for k in 0..3 {
        let r = ratios.map(|m| m[k]);
        assert!(
            r[0] < r[1] && r[1] < r[2],
            "W entry {k}: ratios {r:?} do not rise"
        );
        // The solid is more compliant than Euler-Bernoulli only by shear, (D/L)² ≈ 0.2%.
        assert!(r[2] < 1.01, "W entry {k}: ratios {r:?} above the beam's");
    }
}

#[test]
fn a_cable_bends_coarse_tetrahedra_along_a_beam_of_their_bending_stiffness() {
    let across = 4;
    let stiffer = 1.0 / compliance_ratios(across, 2.0)[2];
    let bend = bends(across, &[stiffer], &[5.0])[0];
    assert!(
        bend.gap <= 0.05 * bend.travel,
        "gap {} m, travel {} m",
        bend.gap,
        bend.travel
    );
}

#[test]
fn the_cylinder_mesh_fills_the_disc_with_well_shaped_tetrahedra() {
    use softsense::fem::mesh::TetMesh;
    let (r, l) = (3.5e-3, 20e-3);
    for across in [2usize, 3, 6, 8] {
        let mesh = TetMesh::cylinder(r, l, across, 10).unwrap();
        let q = mesh.quality().unwrap();
        let disc = std::f64::consts::PI * r * r * l;
        eprintln!(
            "{across} across: volume {:.4} of the disc's, smallest dihedral {:.1}°",
            q.volume / disc,
            q.min_dihedral_deg
        );
        assert!(q.min_volume > 0.0, "{across} across: a flat tetrahedron");
        // The boundary is a polygon through points of the circle.
        assert!(q.volume < disc && q.volume > 0.6 * disc, "{across} across");
        assert!(q.min_dihedral_deg > 5.0, "{across} across: {q:?}");
    }
    assert!(TetMesh::cylinder(r, l, 0, 10).is_err());
    assert!(TetMesh::cylinder(-r, l, 4, 10).is_err());
}

#[test]
fn an_odd_or_absurd_tetrahedral_catheter_is_refused_by_name() {
    use softsense::catheter::tetra::{TetCatheter, TetCatheterParams};
    let cat = crate::common::catheter_tet::catheter(10, 1.0);
    for (across, aspect, field) in [(5, 2.0, "across"), (0, 2.0, "across"), (4, 0.0, "aspect")] {
        let params = TetCatheterParams {
            across,
            aspect,
            ..Default::default()
        };
        let err = TetCatheter::new(&cat, &params).unwrap_err().to_string();
        assert!(err.contains(field), "{across}, {aspect}: {err}");
    }
}
