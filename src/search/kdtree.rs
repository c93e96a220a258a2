//! The KD-tree: kiddo's `ImmutableKdTree` over the finite points, plus exact re-checks
//! of every distance so boundary semantics do not depend on kiddo's internals.

use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use std::num::NonZero;

/// Leaf bucket size of the tree (kiddo's default).
const BUCKET: usize = 32;

type Tree = ImmutableKdTree<f32, u32, 3, BUCKET>;

/// One search result: the index into the slice the tree was built from, and the squared
/// distance to the query (in `f32` or `f64` according to the query used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbour<D = f32> {
    /// Index of the point in the slice given to [`KdTree::build`].
    pub index: usize,
    /// Squared Euclidean distance to the query.
    pub squared_distance: D,
}

/// Options of a radius search.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RadiusQuery {
    /// Sort results by `(squared distance, index)`; otherwise they come in ascending
    /// index order.
    pub sorted: bool,
    /// Keep at most this many results, the closest ones (`None`: all).
    pub max_results: Option<usize>,
    /// Include points at exactly the radius (`d² ≤ r²`); PCL's and Open3D's radius
    /// searches are strict, so this is false by default.
    pub inclusive: bool,
}

impl RadiusQuery {
    /// Sorted, uncapped, strict.
    pub fn sorted() -> Self {
        RadiusQuery {
            sorted: true,
            ..Default::default()
        }
    }
    /// Unsorted, uncapped, strict.
    pub fn unsorted() -> Self {
        RadiusQuery::default()
    }
}

/// Squared distance accumulated in `f32` in FLANN's order: `(dx*dx + dy*dy) + dz*dz`.
#[inline]
pub fn squared_distance(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    let dz = a[2] - b[2];
    (dx * dx + dy * dy) + dz * dz
}

/// Squared distance in `f64` from the widened `f32` coordinates (Open3D's arithmetic).
#[inline]
pub fn squared_distance_f64(a: &[f32; 3], b: &[f32; 3]) -> f64 {
    let dx = a[0] as f64 - b[0] as f64;
    let dy = a[1] as f64 - b[1] as f64;
    let dz = a[2] as f64 - b[2] as f64;
    (dx * dx + dy * dy) + dz * dz
}

/// `r²` as PCL passes it to FLANN: squared in `f64`, then rounded to `f32`.
#[inline]
pub(crate) fn squared_radius_f32(radius: f64) -> f32 {
    (radius * radius) as f32
}

/// A KD-tree over the finite points of a slice of positions.
pub struct KdTree {
    tree: Tree,
    /// Finite points, in tree-item order (item `t` is `points[t]`).
    points: Vec<[f32; 3]>,
    /// Index in the original slice of each tree item.
    original: Vec<u32>,
    /// Number of positions the tree was built from, finite or not.
    source_len: usize,
}

impl std::fmt::Debug for KdTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KdTree")
            .field("points", &self.points.len())
            .field("source_len", &self.source_len)
            .finish()
    }
}

impl KdTree {
    /// Builds the tree from the finite points of `positions`; non-finite points are
    /// skipped (never returned). Panics if there are more than `u32::MAX` points.
    pub fn build(positions: &[[f32; 3]]) -> KdTree {
        assert!(
            positions.len() <= u32::MAX as usize,
            "KdTree::build: more than u32::MAX points"
        );
        let mut points = Vec::with_capacity(positions.len());
        let mut original = Vec::with_capacity(positions.len());
        for (i, p) in positions.iter().enumerate() {
            if p.iter().all(|c| c.is_finite()) {
                points.push(*p);
                original.push(i as u32);
            }
        }
        let tree = Tree::new_from_slice(&points);
        KdTree {
            tree,
            points,
            original,
            source_len: positions.len(),
        }
    }

    /// Number of points in the tree (the finite ones).
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the tree holds no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Number of positions the tree was built from, including skipped non-finite ones.
    pub fn source_len(&self) -> usize {
        self.source_len
    }

    /// Candidate items within a slightly enlarged squared radius (a superset of the
    /// exact answer, whatever kiddo's rounding), as tree items.
    fn candidates(&self, query: &[f32; 3], squared_radius: f64) -> Vec<u32> {
        if self.points.is_empty() || !query.iter().all(|c| c.is_finite()) {
            return Vec::new();
        }
        let widened = (squared_radius * (1.0 + 1e-4) + 1e-30) as f32;
        if widened.is_nan() || widened <= 0.0 {
            return Vec::new();
        }
        self.tree
            .within_unsorted::<SquaredEuclidean>(query, widened.min(f32::MAX))
            .into_iter()
            .map(|n| n.item)
            .collect()
    }

    /// All points within `radius` of `query`, distances in `f32` (PCL's arithmetic).
    /// Strict (`d² < r²`) unless `q.inclusive`. A non-finite query or a radius that is
    /// not positive returns nothing.
    pub fn within_radius(&self, query: &[f32; 3], radius: f64, q: RadiusQuery) -> Vec<Neighbour> {
        self.within(
            query,
            radius,
            squared_radius_f32(radius),
            squared_distance,
            q,
        )
    }

    /// Like [`KdTree::within_radius`] with distances and `r²` in `f64` (Open3D's
    /// arithmetic).
    pub fn within_radius_f64(
        &self,
        query: &[f32; 3],
        radius: f64,
        q: RadiusQuery,
    ) -> Vec<Neighbour<f64>> {
        self.within(query, radius, radius * radius, squared_distance_f64, q)
    }

    /// Radius search with a given distance arithmetic `dist` and squared radius `r2`.
    fn within<D: PartialOrd + Copy + Into<f64>>(
        &self,
        query: &[f32; 3],
        radius: f64,
        r2: D,
        dist: fn(&[f32; 3], &[f32; 3]) -> D,
        q: RadiusQuery,
    ) -> Vec<Neighbour<D>> {
        if radius.is_nan() || radius <= 0.0 {
            return Vec::new();
        }
        let mut out: Vec<Neighbour<D>> = self
            .candidates(query, r2.into())
            .into_iter()
            .filter_map(|t| {
                let d = dist(query, &self.points[t as usize]);
                let inside = if q.inclusive { d <= r2 } else { d < r2 };
                inside.then_some(Neighbour {
                    index: self.original[t as usize] as usize,
                    squared_distance: d,
                })
            })
            .collect();
        finish(&mut out, q);
        out
    }

    /// Number of points with `d² < r²` (or `≤` when `inclusive`), `f32` arithmetic,
    /// counting stops early once `stop_at` is reached (the result is then `stop_at`).
    pub fn count_within_radius(
        &self,
        query: &[f32; 3],
        radius: f64,
        inclusive: bool,
        stop_at: usize,
    ) -> usize {
        if radius.is_nan() || radius <= 0.0 {
            return 0;
        }
        let r2 = squared_radius_f32(radius);
        self.count_inside(query, r2 as f64, stop_at, |p| {
            let d = squared_distance(query, p);
            (inclusive && d <= r2) || d < r2
        })
    }

    /// Number of points with `d² < r²` in `f64` arithmetic (Open3D), stopping at `stop_at`.
    pub fn count_within_radius_f64(&self, query: &[f32; 3], radius: f64, stop_at: usize) -> usize {
        if radius.is_nan() || radius <= 0.0 {
            return 0;
        }
        let r2 = radius * radius;
        self.count_inside(query, r2, stop_at, |p| squared_distance_f64(query, p) < r2)
    }

    /// Number of points for which `inside` holds (it must imply `d ≤ radius`), stopping
    /// at `stop_at`.
    pub(crate) fn count_matching(
        &self,
        query: &[f32; 3],
        radius: f64,
        stop_at: usize,
        inside: impl Fn(&[f32; 3]) -> bool,
    ) -> usize {
        self.count_inside(query, radius * radius, stop_at, inside)
    }

    /// Counts the points for which `inside` holds among the candidates within
    /// `squared_radius` (widened), up to `stop_at`.
    ///
    /// PERF: for a small `stop_at`, first asks kiddo for only the `stop_at` closest
    /// candidates, which prunes the traversal. The answer stays exact whatever kiddo's
    /// rounding: fewer than `stop_at` candidates means that is all of them; `stop_at`
    /// candidates all inside means the count reached `stop_at`; anything else falls back
    /// to the full count.
    fn count_inside(
        &self,
        query: &[f32; 3],
        squared_radius: f64,
        stop_at: usize,
        inside: impl Fn(&[f32; 3]) -> bool,
    ) -> usize {
        if stop_at == 0 || self.points.is_empty() || !query.iter().all(|c| c.is_finite()) {
            return 0;
        }
        if stop_at <= 64 {
            let widened = (squared_radius * (1.0 + 1e-4) + 1e-30).min(f32::MAX as f64) as f32;
            // stop_at == 0 returned above.
            let cap = NonZero::new(stop_at).expect("stop_at > 0");
            let best = self
                .tree
                .nearest_n_within::<SquaredEuclidean>(query, widened, cap, false);
            let n_inside = best
                .iter()
                .filter(|n| inside(&self.points[n.item as usize]))
                .count();
            if best.len() < stop_at || n_inside == stop_at {
                return n_inside;
            }
        }
        let mut count = 0;
        for t in self.candidates(query, squared_radius) {
            if inside(&self.points[t as usize]) {
                count += 1;
                if count >= stop_at {
                    break;
                }
            }
        }
        count
    }

    /// The `k` nearest points, sorted by `(squared distance, index)`, distances in `f32`.
    /// Returns fewer than `k` when the tree is smaller, none for a non-finite query.
    /// Which of several points tied at the k-th distance is returned is unspecified.
    pub fn nearest_n(&self, query: &[f32; 3], k: usize) -> Vec<Neighbour> {
        let Some(k) = NonZero::new(k.min(self.points.len())) else {
            return Vec::new();
        };
        if !query.iter().all(|c| c.is_finite()) {
            return Vec::new();
        }
        let mut out: Vec<Neighbour> = self
            .tree
            .nearest_n::<SquaredEuclidean>(query, k)
            .into_iter()
            .map(|n| Neighbour {
                index: self.original[n.item as usize] as usize,
                squared_distance: squared_distance(query, &self.points[n.item as usize]),
            })
            .collect();
        sort_neighbours(&mut out);
        out
    }

    /// Like [`KdTree::nearest_n`], with squared distances recomputed in `f64`.
    pub fn nearest_n_f64(&self, query: &[f32; 3], k: usize) -> Vec<Neighbour<f64>> {
        let mut out: Vec<Neighbour<f64>> = self
            .nearest_n(query, k)
            .into_iter()
            .map(|n| Neighbour {
                index: n.index,
                squared_distance: squared_distance_f64(query, &self.points_source(n.index)),
            })
            .collect();
        sort_neighbours(&mut out);
        out
    }

    fn points_source(&self, original_index: usize) -> [f32; 3] {
        // original is ascending, so a binary search finds the tree item; the tree only
        // returns indices it was built from.
        let t = self
            .original
            .binary_search(&(original_index as u32))
            .expect("index returned by the tree is in the tree");
        self.points[t]
    }
}

fn sort_neighbours<D: PartialOrd + Copy>(v: &mut [Neighbour<D>]) {
    v.sort_unstable_by(|a, b| {
        a.squared_distance
            .partial_cmp(&b.squared_distance)
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.index.cmp(&b.index))
    });
}

fn finish<D: PartialOrd + Copy>(out: &mut Vec<Neighbour<D>>, q: RadiusQuery) {
    let cap = q.max_results.unwrap_or(usize::MAX);
    if q.sorted || out.len() > cap {
        sort_neighbours(out);
        out.truncate(cap);
        if !q.sorted {
            // Unsorted results come back in index order: reproducible and cheap.
            out.sort_unstable_by_key(|n| n.index);
        }
    } else {
        out.sort_unstable_by_key(|n| n.index);
    }
}
