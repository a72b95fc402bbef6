//! A static kd-tree over 3-D points for k-nearest-neighbour queries.
//!
//! Construction splits each index range at its median along the axis of its largest extent
//! (`select_nth_unstable`), so the tree is balanced and implicit: the node of range
//! $[lo, hi)$ holds the point at $mid = \lfloor (lo+hi)/2 \rfloor$, its children the ranges
//! $[lo, mid)$ and $[mid+1, hi)$; ranges of at most [`LEAF`] points are scanned. Building costs
//! $O(n \log n)$; a query for $k$ neighbours visits $O(\log n + k)$ nodes on well-spread data.
//! Distances are squared Euclidean; ties are broken by the smaller point index, so results do
//! not depend on the build order.

use crate::geometry::mesh::{dot, sub};

/// Ranges of at most this many points are not split.
pub const LEAF: usize = 8;

/// Points (each with a caller's id) in kd order.
#[derive(Debug, Clone)]
pub struct KdTree {
    points: Vec<[f64; 3]>,
    ids: Vec<u32>,
    /// Split axis of the node whose median sits at this index (unused in leaves).
    axis: Vec<u8>,
}

impl KdTree {
    /// Builds the tree over `(id, point)` pairs (ids are returned by the queries).
    pub fn new(items: impl IntoIterator<Item = (u32, [f64; 3])>) -> KdTree {
        let mut items: Vec<(u32, [f64; 3])> = items.into_iter().collect();
        let mut axis = vec![0u8; items.len()];
        build(&mut items, &mut axis, 0);
        KdTree {
            points: items.iter().map(|&(_, p)| p).collect(),
            ids: items.iter().map(|&(i, _)| i).collect(),
            axis,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the tree has no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The `k` points nearest to `q` as `(id, squared distance)`, nearest first (fewer when
    /// the tree holds fewer).
    pub fn nearest(&self, q: [f64; 3], k: usize) -> Vec<(u32, f64)> {
        let mut best: Vec<(f64, u32)> = Vec::with_capacity(k + 1);
        if k > 0 {
            self.search(q, k, 0, self.points.len(), &mut best);
        }
        best.into_iter().map(|(d, i)| (i, d)).collect()
    }

    fn search(&self, q: [f64; 3], k: usize, lo: usize, hi: usize, best: &mut Vec<(f64, u32)>) {
        if hi - lo <= LEAF {
            for i in lo..hi {
                self.offer(q, k, i, best);
            }
            return;
        }
        let mid = (lo + hi) / 2;
        let a = self.axis[mid] as usize;
        let delta = q[a] - self.points[mid][a];
        let (near, far) =
            if delta < 0.0 { ((lo, mid), (mid + 1, hi)) } else { ((mid + 1, hi), (lo, mid)) };
        self.search(q, k, near.0, near.1, best);
        self.offer(q, k, mid, best);
        if best.len() < k || delta * delta <= best[best.len() - 1].0 {
            self.search(q, k, far.0, far.1, best);
        }
    }

    /// Inserts point `i` into the sorted list `best` of at most `k` entries if it is nearer
    /// than its last.
    #[inline]
    fn offer(&self, q: [f64; 3], k: usize, i: usize, best: &mut Vec<(f64, u32)>) {
        let d = sub(self.points[i], q);
        let entry = (dot(d, d), self.ids[i]);
        let closer = |a: &(f64, u32), b: &(f64, u32)| a.0 < b.0 || (a.0 == b.0 && a.1 < b.1);
        if best.len() == k && !closer(&entry, &best[k - 1]) {
            return;
        }
        let at = best.partition_point(|e| closer(e, &entry));
        best.insert(at, entry);
        best.truncate(k);
    }
}

fn build(items: &mut [(u32, [f64; 3])], axis: &mut [u8], offset: usize) {
    let n = items.len();
    if n <= LEAF {
        return;
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (_, p) in items.iter() {
        for d in 0..3 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    }
    let a = (0..3).max_by(|&x, &y| (hi[x] - lo[x]).total_cmp(&(hi[y] - lo[y]))).unwrap_or(0);
    let mid = n / 2;
    items.select_nth_unstable_by(mid, |x, y| x.1[a].total_cmp(&y.1[a]));
    axis[offset + mid] = a as u8;
    let (left, right) = items.split_at_mut(mid);
    build(left, axis, offset);
    build(&mut right[1..], axis, offset + mid + 1);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_matches_brute_force() {
        let mut r = crate::testing::uniform(7);
        let pts: Vec<[f64; 3]> = (0..500).map(|_| [r(), r(), 0.3 * r()]).collect();
        let tree = KdTree::new(pts.iter().enumerate().map(|(i, &p)| (i as u32 * 2, p)));
        assert_eq!(tree.len(), 500);
        for _ in 0..50 {
            let q = [1.5 * r(), r(), r()];
            for k in [1, 5, 40] {
                let mut brute: Vec<(f64, u32)> = pts
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (dot(sub(*p, q), sub(*p, q)), i as u32 * 2))
                    .collect();
                brute.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                let got = tree.nearest(q, k);
                let want: Vec<(u32, f64)> = brute[..k].iter().map(|&(d, i)| (i, d)).collect();
                assert_eq!(got, want);
            }
        }
        assert_eq!(KdTree::new([(3, [0.0; 3])]).nearest([1.0; 3], 4), vec![(3, 3.0)]);
        assert!(KdTree::new([]).nearest([0.0; 3], 2).is_empty());
    }
}
