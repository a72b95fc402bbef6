//! Vertex regions on a mesh graph: growing and shrinking by one ring of edges, the vertices
//! connected to a region, and the complement. The editor's selection tools use them to edit
//! handle groups.
//!
//! A region is a mask: `#V` booleans, `true` for a vertex in it. "Neighbour" means sharing a
//! mesh edge ([`Adjacency`]). Every function is `O(#V + #E)` and returns a new mask of the
//! same length; a mask of another length than the adjacency's vertex count is an error of the
//! caller and is answered by debug assertions (in release, out-of-range vertices are
//! skipped, never a panic).

use super::topology::Adjacency;

fn n_vertices(adjacency: &Adjacency, region: &[bool]) -> usize {
    debug_assert_eq!(
        adjacency.n_vertices(),
        region.len(),
        "region mask length differs from the mesh's vertex count"
    );
    adjacency.n_vertices().min(region.len())
}

/// The region plus every vertex one edge away from it:
/// $\operatorname{grow}(S) = S \cup \{ v : \exists u \in S,\ (u, v) \in E \}$.
///
/// Inputs: `adjacency` over `#V` vertices, `region` `#V` bool. Output: `#V` bool.
pub fn grow(adjacency: &Adjacency, region: &[bool]) -> Vec<bool> {
    let n = n_vertices(adjacency, region);
    let mut out = region.to_vec();
    for (v, _) in region.iter().enumerate().take(n).filter(|(_, r)| **r) {
        for &w in adjacency.neighbors(v as u32) {
            if let Some(o) = out.get_mut(w as usize) {
                *o = true;
            }
        }
    }
    out
}

/// The region less its boundary ring: the vertices of `region` all of whose neighbours are in
/// it, $\operatorname{shrink}(S) = \{ v \in S : \forall (v, u) \in E,\ u \in S \}$.
///
/// The dual of [`grow`]: `shrink(S) = ¬grow(¬S)`; `shrink(grow(S)) ⊇ S`, with equality when
/// no vertex outside `S` has all its neighbours in `grow(S)` (e.g. a single interior vertex).
/// An isolated vertex (no edges) of the region stays.
///
/// Inputs: `adjacency` over `#V` vertices, `region` `#V` bool. Output: `#V` bool.
pub fn shrink(adjacency: &Adjacency, region: &[bool]) -> Vec<bool> {
    let n = n_vertices(adjacency, region);
    let mut out = region.to_vec();
    for (v, o) in out.iter_mut().enumerate().take(n) {
        if *o {
            *o = adjacency
                .neighbors(v as u32)
                .iter()
                .all(|&w| region.get(w as usize) == Some(&true));
        }
    }
    out
}

/// Every vertex reachable from a vertex of `seeds` along mesh edges (flood fill), the seeds
/// included: the union of the connected components that `seeds` touches.
///
/// Inputs: `adjacency` over `#V` vertices, `seeds` `#V` bool. Output: `#V` bool.
pub fn connected(adjacency: &Adjacency, seeds: &[bool]) -> Vec<bool> {
    let n = n_vertices(adjacency, seeds);
    let mut out = seeds.to_vec();
    let mut stack: Vec<u32> = (0..n as u32).filter(|&v| seeds[v as usize]).collect();
    while let Some(v) = stack.pop() {
        for &w in adjacency.neighbors(v) {
            if let Some(o) = out.get_mut(w as usize)
                && !*o
            {
                *o = true;
                stack.push(w);
            }
        }
    }
    out
}

/// The complement within `allowed`: vertices of `allowed` not in `region`
/// ($A \setminus S$). Vertices outside `allowed` (e.g. those of other handle groups) are
/// never added.
///
/// Inputs: `region`, `allowed`, both `#V` bool. Output: `#V` bool.
pub fn invert(region: &[bool], allowed: &[bool]) -> Vec<bool> {
    debug_assert_eq!(region.len(), allowed.len(), "region and allowed masks differ in length");
    region.iter().zip(allowed).map(|(&r, &a)| a && !r).collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    /// A `w × h` grid of vertices, two triangles per cell; vertex `(x, y)` is `y * w + x`.
    fn grid(w: u32, h: u32) -> (usize, Vec<[u32; 3]>) {
        let mut t = Vec::new();
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                let v = y * w + x;
                t.push([v, v + 1, v + w]);
                t.push([v + 1, v + w + 1, v + w]);
            }
        }
        ((w * h) as usize, t)
    }

    fn mask(n: usize, vs: &[u32]) -> Vec<bool> {
        let mut m = vec![false; n];
        for &v in vs {
            m[v as usize] = true;
        }
        m
    }

    fn set(m: &[bool]) -> Vec<u32> {
        (0..m.len() as u32).filter(|&v| m[v as usize]).collect()
    }

    #[test]
    fn grow_adds_one_ring_and_shrink_takes_it_back() {
        let (n, t) = grid(5, 5);
        let adj = Adjacency::new(n, &t);
        let centre = mask(n, &[12]);
        let grown = grow(&adj, &centre);
        // The centre (2, 2) and its six neighbours in this triangulation.
        assert_eq!(set(&grown), vec![7, 8, 11, 12, 13, 16, 17]);
        assert_eq!(shrink(&adj, &grown), centre, "grow then shrink round-trips");
        // Two rings do not always shrink back: a vertex outside `S` whose neighbours are
        // all in grow(S) stays (here the grid's anti-diagonal through the centre).
        let twice = grow(&adj, &grown);
        assert_eq!(set(&shrink(&adj, &shrink(&adj, &twice))), vec![4, 8, 12, 16, 20]);
        // Shrinking a single vertex empties it; growing nothing stays nothing.
        assert!(set(&shrink(&adj, &centre)).is_empty());
        assert!(set(&grow(&adj, &vec![false; n])).is_empty());
    }

    #[test]
    fn shrink_is_the_dual_of_grow() {
        let (n, t) = grid(6, 4);
        let adj = Adjacency::new(n, &t);
        let s = mask(n, &[0, 1, 2, 6, 7, 8, 9, 13, 14, 20]);
        let not = |m: &[bool]| m.iter().map(|b| !b).collect::<Vec<_>>();
        assert_eq!(shrink(&adj, &s), not(&grow(&adj, &not(&s))));
        let closed = shrink(&adj, &grow(&adj, &s));
        assert!(s.iter().zip(&closed).all(|(a, b)| !a || *b), "shrink(grow(S)) contains S");
    }

    #[test]
    fn connected_floods_the_touched_components_only() {
        // Two triangles sharing an edge, one separate triangle, one isolated vertex.
        let t = vec![[0, 1, 2], [1, 3, 2], [4, 5, 6]];
        let adj = Adjacency::new(8, &t);
        assert_eq!(set(&connected(&adj, &mask(8, &[3]))), vec![0, 1, 2, 3]);
        assert_eq!(set(&connected(&adj, &mask(8, &[5, 7]))), vec![4, 5, 6, 7]);
        assert!(set(&connected(&adj, &[false; 8])).is_empty());
        // An isolated vertex stays under shrink (it has no neighbour outside).
        assert_eq!(set(&shrink(&adj, &mask(8, &[7]))), vec![7]);
    }

    #[test]
    fn invert_stays_inside_the_allowed_vertices() {
        let region = vec![true, false, false, true];
        let allowed = vec![true, true, false, true];
        assert_eq!(invert(&region, &allowed), vec![false, true, false, false]);
        assert_eq!(invert(&invert(&region, &allowed), &allowed), vec![true, false, false, true]);
    }
}
