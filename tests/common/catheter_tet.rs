//! The beam against the catheter as tetrahedra ([`softsense::catheter::tetra`]), shared by
//! the unit tier (coarse meshes) and the acceptance tier (fine ones).

use softsense::catheter::rig::Catheter;
use softsense::catheter::scenario::Scenario;
use softsense::catheter::tetra::{TetCatheter, TetCatheterParams};
use softsense::fem::beam::{BeamLoads, BeamParams, BeamRow};
use softsense::fem::constraint::{ConstraintRow, RowKind};
use softsense::fem::solve::{CableControl, Formulation, MappedPoint, NewtonParams};

/// The default catheter (166 mm, 7 mm, 44.8 MPa, 4 cables at 2.5 mm) with `elements`
/// beam elements and its modulus times `young_factor`.
pub fn catheter(elements: usize, young_factor: f64) -> Catheter {
    let text = format!(
        "[tube]\ndiameter_mm = 28\npieces = [{{ kind = \"straight\", length_mm = 180 }}]\n\
         [insertion]\nspeed_mm_per_s = 1.0\nend_mm = 100\n\
         [catheter]\nelements = {elements}\nyoung_modulus = {}\n",
        44.8e6 * young_factor
    );
    Scenario::parse(&text, "test.toml")
        .unwrap()
        .catheter(false)
        .unwrap()
}

/// The default catheter as tetrahedra, `across` cells over the diameter.
pub fn tet(across: usize, aspect: f64, formulation: Formulation) -> TetCatheter {
    let params = TetCatheterParams {
        across,
        aspect,
        formulation,
    };
    TetCatheter::new(&catheter(10, 1.0), &params).unwrap()
}

/// W_tet / W_beam, element by element, over the transverse rows (section y) at the middle
/// slice and the tip; the beam has a node at every slice.
pub fn compliance_ratios(across: usize, aspect: f64) -> [f64; 3] {
    let t = tet(across, aspect, Formulation::SmallStrain);
    let along = t.centreline.len() - 1;
    let stations = [along / 2, along];
    let x = t.problem.initial_positions();
    let rows: Vec<ConstraintRow> = (stations.iter())
        .map(|&i| {
            let at = MappedPoint::node(t.centreline[i]);
            ConstraintRow::along(RowKind::Force, &at, [0.0, 1.0, 0.0]).unwrap()
        })
        .collect();
    let w_tet = t
        .problem
        .solver()
        .unwrap()
        .compliance_at(&x, &rows)
        .unwrap()
        .w;
    let beam = catheter(along, 1.0).beam;
    let beam_rows: Vec<BeamRow> = (stations.iter())
        .map(|&i| BeamRow::translation(i, [0.0, 1.0, 0.0]))
        .collect();
    let w_beam = beam
        .linearise(&beam.rest_state())
        .unwrap()
        .compliance(&beam_rows);
    let r = [(0, 0), (0, 1), (1, 1)].map(|(i, j)| w_tet[(i, j)] / w_beam[(i, j)]);
    eprintln!(
        "{across} across, aspect {aspect}: {} nodes, W_tet / W_beam mid {:.4}, mid-tip {:.4}, tip {:.4}",
        x.len(),
        r[0],
        r[1],
        r[2]
    );
    r
}

/// One cable tension's comparison with one beam: the tip's travel and the largest gap
/// between the tetrahedra's centreline and the beam's (m), and both tip angles (rad).
#[derive(Debug, Clone, Copy)]
pub struct Bend {
    pub tension: f64,
    pub young_factor: f64,
    pub travel: f64,
    pub gap: f64,
    pub tet_angle: f64,
    pub beam_angle: f64,
}

/// The tetrahedra (corotational) under `tensions` on cable 0 against the catheter's own
/// 10-element beam with its modulus times each of `young_factors`, compared at the beam's
/// nodes (the tetrahedra's centreline interpolated there).
pub fn bends(across: usize, young_factors: &[f64], tensions: &[f64]) -> Vec<Bend> {
    let mut t = tet(across, 2.0, Formulation::Corotational);
    let along = t.centreline.len() - 1;
    let tip_rest = t.problem.initial_positions()[t.centreline[along]];
    let mut out = Vec::new();
    for &tension in tensions {
        t.problem.cables[0].control = CableControl::Force(tension);
        let newton = NewtonParams {
            load_steps: (tension / 2.5).ceil().max(1.0) as usize,
            ..Default::default()
        };
        let sol = t.problem.solve_static(&newton).unwrap();
        assert!(sol.converged, "tetrahedra at {tension} N did not converge");
        let centre: Vec<[f64; 3]> = t.centreline.iter().map(|&v| sol.positions[v]).collect();
        for &young_factor in young_factors {
            let (gap, beam_angle) = beam_gap(young_factor, tension, &centre);
            let last = [0, 1, 2].map(|d| centre[along][d] - centre[along - 1][d]);
            let along_x = last[0] / dist(centre[along], centre[along - 1]);
            let bend = Bend {
                tension,
                young_factor,
                travel: dist(centre[along], tip_rest),
                gap,
                tet_angle: along_x.clamp(-1.0, 1.0).acos(),
                beam_angle,
            };
            eprintln!(
                "{across} across, beam E x {young_factor:.3}, {tension:>4} N: tip travel {:.2} mm, largest gap {:.3} mm ({:.2}%), tip angle tet {:.1}°, beam {:.1}°",
                1e3 * bend.travel,
                1e3 * bend.gap,
                100.0 * bend.gap / bend.travel,
                bend.tet_angle.to_degrees(),
                bend.beam_angle.to_degrees()
            );
            out.push(bend);
        }
    }
    out
}

/// The largest gap (m) between the 10-element beam with its modulus times `young_factor`
/// under `tension` on cable 0 and the tetrahedra's centreline `centre`, and the beam's
/// tip angle (rad).
fn beam_gap(young_factor: f64, tension: f64, centre: &[[f64; 3]]) -> (f64, f64) {
    let cat = catheter(10, young_factor);
    let loads = BeamLoads {
        cables: vec![(cat.cables[0], tension)],
        ..Default::default()
    };
    // The cable's load stiffness is not in the beam's tangent, so near 90° Newton
    // converges linearly and slowly (about 2,000 iterations in all at 20 N).
    let params = BeamParams {
        load_steps: 8,
        max_iterations: 2000,
        ..Default::default()
    };
    let beam = (cat
        .beam
        .solve_static(&cat.beam.rest_state(), &loads, &params))
    .unwrap();
    assert!(
        beam.status.is_converged(),
        "beam at {tension} N: {:?}",
        beam.status
    );
    let (n, along) = (beam.state.nodes_in_world.len() - 1, centre.len() - 1);
    let gap = (0..=n)
        .map(|i| {
            let s = (i * along) as f64 / n as f64;
            let k = (s.floor() as usize).min(along - 1);
            let f = s - k as f64;
            let p: [f64; 3] =
                std::array::from_fn(|d| (1.0 - f) * centre[k][d] + f * centre[k + 1][d]);
            dist(p, beam.state.nodes_in_world[i].into())
        })
        .fold(0.0, f64::max);
    let beam_tip = beam.state.world_from_node[n] * nalgebra::Vector3::x();
    (gap, beam_tip.x.clamp(-1.0, 1.0).acos())
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
