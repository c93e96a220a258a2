//! Residuals of the features along their normals, with their noise from the sensor model,
//! and the chi-square statistics per region.

use super::effects::{apply_model, correct_points, Effect};
use super::explanation::{RegionStats, Residual};
use super::features::{measure_offset, REGION_NAMES};
use super::frame::solve_frame;
use super::workflow::Workflow;
use super::DiscrepancyResult;
use crate::geometry::raycast::Bvh;
use crate::register::Registrar;

impl Workflow<'_> {
    /// Exact residuals of frame `i` with the effects applied.
    pub(super) fn residuals(
        &self,
        i: usize,
        effects: &[Effect],
    ) -> DiscrepancyResult<Vec<Residual>> {
        let ctx = &self.frames[i];
        // Measurement effects alone leave the nominal solution as it is.
        let solved;
        let x = if effects.iter().any(|e| e.kind.is_model()) {
            let mut prob = ctx.problem.clone();
            apply_model(&mut prob, effects, &self.legs)?;
            solved = solve_frame(self.model, &prob, i, Some(&ctx.nominal))?;
            &solved.positions
        } else {
            &ctx.nominal.positions
        };
        let cam = &self.rec.camera;
        let pts = correct_points(&self.rec.frames[i].points, effects, cam);
        let registrar = Registrar::new(&pts);
        let bvh = Bvh::new(x, &self.triangles);
        let eye = cam.eye();
        let s = &self.rec.sensor;
        let cos_max = self.params.max_view_angle_deg.to_radians().cos();
        let mut out = Vec::new();
        for (fi, f) in self.features.iter().enumerate() {
            let (p, n) = f.at(x);
            let d = [0, 1, 2].map(|k| p[k] - eye[k]);
            let dl = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let facing = -(0..3).map(|k| n[k] * d[k]).sum::<f64>() / dl.max(1e-12);
            if facing < cos_max {
                continue;
            }
            // Occluded when the view ray hits another surface clearly before the feature.
            if let Some(h) = bvh.cast(eye, d) {
                if h.t < 1.0 - 2e-3 / dl.max(1e-12) {
                    continue;
                }
            }
            let Some(m) = measure_offset(&registrar, p, n, &self.register) else {
                continue;
            };
            if m.points < self.params.min_points {
                continue;
            }
            let z = cam.depth_of(p);
            let nd = facing * dl / z.max(1e-9);
            let sz2 = (s.depth_k * z * z).powi(2) * f64::from(u8::from(s.enabled))
                + s.depth_unit * s.depth_unit / 12.0;
            let sigma2 = sz2 * nd * nd / m.points as f64 + self.params.sigma_floor.powi(2);
            out.push(Residual {
                feature: fi,
                r: m.offset,
                sigma: sigma2.sqrt(),
            });
        }
        Ok(out)
    }

    /// Exact residuals of every frame with the effects applied.
    pub(super) fn all_residuals(
        &self,
        effects: &[Effect],
    ) -> DiscrepancyResult<Vec<Vec<Residual>>> {
        (0..self.frames.len())
            .map(|i| self.residuals(i, effects))
            .collect()
    }

    /// Residuals of `frames` only (the others empty).
    pub(super) fn some_residuals(
        &self,
        frames: &[usize],
        effects: &[Effect],
    ) -> DiscrepancyResult<Vec<Vec<Residual>>> {
        (0..self.frames.len())
            .map(|i| {
                if frames.contains(&i) {
                    self.residuals(i, effects)
                } else {
                    Ok(Vec::new())
                }
            })
            .collect()
    }

    /// Per-region statistics over `frames` (last entry: all regions).
    pub(super) fn stats(&self, res: &[Vec<Residual>], frames: &[usize]) -> Vec<RegionStats> {
        let nreg = REGION_NAMES.len();
        let mut acc = vec![(0usize, 0.0f64, 0.0f64, 0.0f64); nreg + 1];
        for &i in frames {
            for r in &res[i] {
                let g = self.features[r.feature].region;
                for a in [g, nreg] {
                    acc[a].0 += 1;
                    acc[a].1 += (r.r / r.sigma).powi(2);
                    acc[a].2 += r.r * r.r;
                    acc[a].3 += r.sigma * r.sigma;
                }
            }
        }
        acc.iter()
            .enumerate()
            .map(|(g, &(n, chi2, rr, ss))| {
                let nf = n.max(1) as f64;
                RegionStats {
                    region: REGION_NAMES.get(g).copied().unwrap_or("all").to_string(),
                    n,
                    chi2,
                    z: if n > 0 {
                        (chi2 - nf) / (2.0 * nf).sqrt()
                    } else {
                        0.0
                    },
                    rms: (rr / nf).sqrt(),
                    noise_rms: (ss / nf).sqrt(),
                }
            })
            .collect()
    }

    /// χ² and residual rows over `frames`.
    pub(super) fn chi2(&self, res: &[Vec<Residual>], frames: &[usize]) -> (f64, usize) {
        frames
            .iter()
            .flat_map(|&i| &res[i])
            .fold((0.0, 0), |(c, n), r| (c + (r.r / r.sigma).powi(2), n + 1))
    }
}
