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
