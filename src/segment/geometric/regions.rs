//! Steps 3 to 5 of the geometric segmentation: smooth region growing off the support,
//! small regions joined to their most-connected neighbour, and the convexity and colour
//! merge of adjacent regions (a union-find over the grown regions).

use super::{dot, norm, sub, GeometricParams, PointGeometry};
use crate::segment::color::delta_e;
use std::collections::HashMap;

/// No region (support points, and points no growth reached).
const NONE: u32 = u32::MAX;

/// The grown regions and their merges.
pub(super) struct Regions {
    /// Per point: the grown region, or [`NONE`].
    region: Vec<u32>,
    /// Regions grown.
    pub(super) count: u32,
    /// Union-find parent of each grown region.
    parent: Vec<u32>,
}

impl Regions {
    /// Step 3: smooth region growing off the support, in ascending curvature order.
    pub(super) fn grow(
        geo: &PointGeometry,
        on_plane: &[bool],
        params: &GeometricParams,
    ) -> Regions {
        let (nrm, curv, nbrs) = (&geo.nrm, &geo.curv, &geo.nbrs);
        let m = nrm.len();
        let cos_smooth = params.smoothness_deg.to_radians().cos();
        let mut order: Vec<usize> = (0..m).filter(|&i| !on_plane[i]).collect();
        order.sort_by(|&a, &b| {
            let key = |i: usize| {
                if curv[i].is_finite() {
                    curv[i]
                } else {
                    f32::INFINITY
                }
            };
            key(a).total_cmp(&key(b)).then(a.cmp(&b))
        });
        let mut region = vec![NONE; m];
        let mut n_regions = 0u32;
        let mut queue = Vec::new();
        for &seed in &order {
            if region[seed] != NONE {
                continue;
            }
            let r = n_regions;
            n_regions += 1;
            region[seed] = r;
            queue.push(seed);
            while let Some(cur) = queue.pop() {
                let Some(nc) = nrm[cur] else { continue };
                for &q in &nbrs[cur] {
                    let q = q as usize;
                    if region[q] != NONE || on_plane[q] {
                        continue;
                    }
                    let Some(nq) = nrm[q] else { continue };
                    if dot(nc, nq).abs() < cos_smooth {
                        continue;
                    }
                    region[q] = r;
                    if curv[q] < params.curvature_max as f32 {
                        queue.push(q);
                    }
                }
            }
        }
        Regions {
            region,
            count: n_regions,
            parent: (0..n_regions).collect(),
        }
    }

    /// Step 4: small regions join their most-connected neighbour.
    pub(super) fn merge_small(&mut self, nbrs: &[Vec<u32>], min_points: usize) {
        let (region, parent) = (&self.region, &mut self.parent);
        let mut size = vec![0usize; self.count as usize];
        for &r in region.iter().filter(|&&r| r != NONE) {
            size[r as usize] += 1;
        }
        for _pass in 0..8 {
            let adj = adjacency(region, nbrs, parent);
            let mut best: HashMap<u32, (usize, u32)> = HashMap::new();
            for (&(a, b), &count) in &adj {
                for (x, y) in [(a, b), (b, a)] {
                    if size[x as usize] < min_points {
                        let e = best.entry(x).or_insert((0, y));
                        if count > e.0 || (count == e.0 && y < e.1) {
                            *e = (count, y);
                        }
                    }
                }
            }
            let mut small: Vec<(usize, u32)> =
                best.keys().map(|&r| (size[r as usize], r)).collect();
            small.sort_unstable();
            let mut changed = false;
            for (_, r) in small {
                let (ra, rb) = (find(parent, r), find(parent, best[&r].1));
                if ra == rb || size[ra as usize] >= min_points {
                    continue;
                }
                parent[ra as usize] = rb;
                size[rb as usize] += size[ra as usize];
                size[ra as usize] = 0;
                changed = true;
            }
            if !changed {
                break;
            }
        }
    }

    /// Step 5: adjacent regions merge unless their junction is concave; flat junctions
    /// only when the mean colours (CIELAB `labs`, per point) are close.
    pub(super) fn merge_convex(
        &mut self,
        geo: &PointGeometry,
        pts: &[[f32; 3]],
        labs: Option<&[[f64; 3]]>,
        min_points: usize,
        params: &GeometricParams,
    ) {
        let means = self.means(geo, labs);
        let pairs = self.junctions(geo, pts, &means.normal);
        let sin_c = params.concavity_deg.to_radians().sin();
        let (rc, rcount) = (&means.colour, &means.count);
        for ((a, b), (count, sum)) in pairs {
            if count < params.min_boundary_pairs
                || rcount[a as usize] < min_points as f64
                || rcount[b as usize] < min_points as f64
            {
                continue;
            }
            let c = sum / count as f64;
            let merge = if c > sin_c {
                false
            } else if c < -sin_c {
                true
            } else {
                labs.is_none()
                    || delta_e(rc[a as usize], rc[b as usize]) < params.flat_merge_delta_e
            };
            if merge {
                let (ra, rb) = (find(&mut self.parent, a), find(&mut self.parent, b));
                if ra != rb {
                    self.parent[ra.max(rb) as usize] = ra.min(rb);
                }
            }
        }
    }

    /// Per current root region: unit mean normal, mean colour and point count.
    fn means(&mut self, geo: &PointGeometry, labs: Option<&[[f64; 3]]>) -> RegionMeans {
        let grown = self.count as usize;
        let mut rn = vec![[0f64; 3]; grown];
        let mut rc = vec![[0f64; 3]; grown];
        let mut rcount = vec![0f64; grown];
        for i in 0..self.region.len() {
            if self.region[i] == NONE {
                continue;
            }
            let r = find(&mut self.parent, self.region[i]) as usize;
            if let Some(n) = geo.nrm[i] {
                for a in 0..3 {
                    rn[r][a] += n[a];
                }
            }
            if let Some(l) = labs {
                for a in 0..3 {
                    rc[r][a] += l[i][a];
                }
            }
            rcount[r] += 1.0;
        }
        for r in 0..grown {
            let len = norm(rn[r]);
            if len > 0.0 {
                rn[r] = rn[r].map(|v| v / len);
            }
            if rcount[r] > 0.0 {
                rc[r] = rc[r].map(|v| v / rcount[r]);
            }
        }
        RegionMeans {
            normal: rn,
            colour: rc,
            count: rcount,
        }
    }

    /// Per pair of adjacent root regions `(a < b)`, ascending: the number of neighbour
    /// pairs across the junction and the sum of `(nA - nB)·d` over them.
    fn junctions(
        &mut self,
        geo: &PointGeometry,
        pts: &[[f32; 3]],
        rn: &[[f64; 3]],
    ) -> Vec<((u32, u32), (usize, f64))> {
        let region = &self.region;
        let snapshot: Vec<u32> = (0..self.count).map(|r| find(&mut self.parent, r)).collect();
        let mut conv: HashMap<(u32, u32), (usize, f64)> = HashMap::new();
        for i in 0..region.len() {
            if region[i] == NONE {
                continue;
            }
            let a = snapshot[region[i] as usize];
            for &j in &geo.nbrs[i] {
                let j = j as usize;
                if region[j] == NONE {
                    continue;
                }
                let b = snapshot[region[j] as usize];
                if a >= b {
                    continue;
                }
                let d = sub(pts[j], pts[i]);
                let len = norm(d);
                if len == 0.0 {
                    continue;
                }
                let na = rn[a as usize];
                let nb = rn[b as usize];
                let c = dot([na[0] - nb[0], na[1] - nb[1], na[2] - nb[2]], d) / len;
                let e = conv.entry((a, b)).or_insert((0, 0.0));
                e.0 += 1;
                e.1 += c;
            }
        }
        let mut pairs: Vec<((u32, u32), (usize, f64))> = conv.into_iter().collect();
        pairs.sort_unstable_by_key(|p| p.0);
        pairs
    }

    /// The merged regions of at least `min_points` points, as `(false, cloud indices)`
    /// (`finite` maps point to cloud index), in no particular order.
    pub(super) fn clusters(
        &mut self,
        finite: &[usize],
        min_points: usize,
    ) -> Vec<(bool, Vec<usize>)> {
        let mut groups: HashMap<u32, Vec<usize>> = HashMap::new();
        for (&r, &i) in self.region.iter().zip(finite) {
            if r != NONE {
                groups.entry(find(&mut self.parent, r)).or_default().push(i);
            }
        }
        groups
            .into_values()
            .filter(|g| g.len() >= min_points)
            .map(|g| (false, g))
            .collect()
    }
}

/// Per root region (indexed by region): unit mean normal, mean CIELAB colour, points.
struct RegionMeans {
    normal: Vec<[f64; 3]>,
    colour: Vec<[f64; 3]>,
    count: Vec<f64>,
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

/// Neighbour-pair counts between the current root regions (each directed neighbour
/// relation counted), keyed by `(smaller root, larger root)`.
fn adjacency(region: &[u32], nbrs: &[Vec<u32>], parent: &mut [u32]) -> HashMap<(u32, u32), usize> {
    let mut adj: HashMap<(u32, u32), usize> = HashMap::new();
    for (i, list) in nbrs.iter().enumerate() {
        if region[i] == u32::MAX {
            continue;
        }
        let a = find(parent, region[i]);
        for &j in list {
            let j = j as usize;
            if region[j] == u32::MAX {
                continue;
            }
            let b = find(parent, region[j]);
            if a != b {
                *adj.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
    }
    adj
}
