//! The mesh's part of the Galerkin coarse energy's coefficients ([`GalerkinMesh`]), as data: the
//! sums over the full mesh's edges (gathered by `gathering.rs`, once per mesh and coarse base;
//! module doc of `galerkin/mod.rs`, "The restriction"), and their bytes in the disk cache.

use crate::deform::arap::Csr;
use crate::linalg::linsolve::SpdPattern;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::OnceLock;

/// A map whose iteration order depends only on what was inserted (fixed hash keys), so that the
/// sums gathered from it, and so the iterations, are the same from run to run.
pub(crate) type FixedMap<K, V> = HashMap<K, V, BuildHasherDefault<KeyHasher>>;

/// The gathering maps' hash of a [`key`]: MurmurHash3's 64-bit finalizer (Appleby), which mixes
/// both packed indices into every bit of the hash in a few multiplications, where std's keyed
/// SipHash does several rounds; fixed, so the maps' order stays the same from run to run.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn write_u64(&mut self, k: u64) {
        let mut h = self.0 ^ k;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        self.0 = h ^ (h >> 33);
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// The mesh's part of the Galerkin coarse energy's coefficients for one coarse base: the sums
/// over the full mesh's edges of $G$ and of the $g_{kb}$ (module doc), and the coarse mesh's
/// weights; everything but the handles' terms, so gathered once per mesh and coarse base and
/// shared by every handle set ([`super::GalerkinCoarse::new`]).
#[derive(Debug, Clone)]
pub struct GalerkinMesh {
    /// The entries $G_{ab}$, $a \ge b$, by key $(a, b)$.
    pub(super) g: FixedMap<u64, f64>,
    /// The $g_{kb}$ by key $(k, b)$.
    pub(super) pair: FixedMap<u64, [f64; 3]>,
    /// $\max_a G_{aa}$, the scale of the handles' penalty.
    pub(super) g_max: f64,
    /// The median of the $G_{aa}$, the scale of [`super::HandleRule::PenaltyOfMedian`].
    pub(super) g_median: f64,
    /// $\sum_{(i,j)} w_{ij}\lVert\beta_i - \beta_j\rVert^2$ over ordered pairs: the energy's
    /// constant from the edges.
    pub(super) rest_term: f64,
    /// The coarse mesh's clamped cotangent edges: per cluster $k$, its $(l, w^c_{kl})$.
    pub(super) neighbours: Csr<(u32, f64)>,
    /// The full and the coarse mesh's vertex counts it was gathered for.
    pub(super) sizes: (usize, usize),
    /// The analysis of the coarse matrix's pattern, from the first handle set whose free block
    /// is every coarse vertex (the exact rule): the pattern of $G$, which the handles' terms
    /// change only in value, so later handle sets factor on it without a new ordering.
    pub(super) pattern: OnceLock<SpdPattern>,
}

/// The key of the pair $(a, b)$ in the gathering maps.
pub(crate) fn key(a: u32, b: u32) -> u64 {
    (u64::from(a) << 32) | u64::from(b)
}

/// The pair $(a, b)$ of a key of the gathering maps ([`key`]'s inverse).
pub(crate) fn pair_of(key: u64) -> (u32, u32) {
    ((key >> 32) as u32, key as u32)
}

/// A keyed sum as a `(row, (column, value))` entry for [`Csr::from_pairs`].
pub(crate) fn row_entry<V>((key, value): (u64, V)) -> (u32, (u32, V)) {
    let (row, column) = pair_of(key);
    (row, (column, value))
}

impl GalerkinMesh {
    /// The part as bytes for the disk cache (`coarse/cache.rs`), little-endian: $G$'s entries
    /// and the $g_{kb}$ as (key, values) sorted by key, $\max G_{aa}$, the median, the rest
    /// term, and the coarse mesh's edges as (cluster, cluster, weight) in row order.
    pub(crate) fn encode(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut g: Vec<_> = self.g.iter().map(|(&k, &v)| (k, v)).collect();
        g.sort_unstable_by_key(|e| e.0);
        out.extend((g.len() as u64).to_le_bytes());
        for (k, v) in g {
            out.extend(k.to_le_bytes());
            out.extend(v.to_le_bytes());
        }
        let mut pair: Vec<_> = self.pair.iter().map(|(&k, &v)| (k, v)).collect();
        pair.sort_unstable_by_key(|e| e.0);
        out.extend((pair.len() as u64).to_le_bytes());
        for (k, v) in pair {
            out.extend(k.to_le_bytes());
            v.iter().for_each(|x| out.extend(x.to_le_bytes()));
        }
        for x in [self.g_max, self.g_median, self.rest_term] {
            out.extend(x.to_le_bytes());
        }
        let m = self.sizes.1;
        let edges: Vec<(u32, u32, f64)> = (0..m)
            .flat_map(|k| self.neighbours.row(k).iter().map(move |&(l, w)| (k as u32, l, w)))
            .collect();
        out.extend((edges.len() as u64).to_le_bytes());
        for (k, l, w) in edges {
            out.extend(k.to_le_bytes());
            out.extend(l.to_le_bytes());
            out.extend(w.to_le_bytes());
        }
        out
    }

    /// The part [`GalerkinMesh::encode`] wrote, for a mesh of `n` vertices and a coarse mesh
    /// of `m`; every count, index and number checked, the reason when one is wrong.
    pub(crate) fn decode(bytes: &[u8], n: usize, m: usize) -> Result<GalerkinMesh, &'static str> {
        let mut r = bytes;
        let mut take = |k: usize| -> Result<&[u8], &'static str> {
            if r.len() < k {
                return Err("short Galerkin part");
            }
            let (head, rest) = r.split_at(k);
            r = rest;
            Ok(head)
        };
        let u64_at = |b: &[u8]| u64::from_le_bytes(b.try_into().unwrap_or_default());
        let f64_at = |b: &[u8]| f64::from_bits(u64_at(b));
        let in_range = |key: u64| {
            let (a, b) = pair_of(key);
            (a as usize) < m && (b as usize) < m
        };
        let count = |c: u64, size: usize, left: usize| -> Result<usize, &'static str> {
            let c = usize::try_from(c).map_err(|_| "Galerkin count")?;
            if c.checked_mul(size).is_none_or(|b| b > left) {
                return Err("Galerkin count out of range");
            }
            Ok(c)
        };
        let ng = u64_at(take(8)?);
        let ng = count(ng, 16, bytes.len())?;
        let mut g = FixedMap::default();
        for _ in 0..ng {
            let e = take(16)?;
            let (k, v) = (u64_at(&e[..8]), f64_at(&e[8..]));
            let (a, b) = pair_of(k);
            if !in_range(k) || a < b || !v.is_finite() {
                return Err("a Galerkin entry out of range");
            }
            g.insert(k, v);
        }
        let np = u64_at(take(8)?);
        let np = count(np, 32, bytes.len())?;
        let mut pair = FixedMap::default();
        for _ in 0..np {
            let e = take(32)?;
            let k = u64_at(&e[..8]);
            let v = [f64_at(&e[8..16]), f64_at(&e[16..24]), f64_at(&e[24..])];
            if !in_range(k) || !v.iter().all(|x| x.is_finite()) {
                return Err("a Galerkin pair out of range");
            }
            pair.insert(k, v);
        }
        let s = take(24)?;
        let (g_max, g_median, rest_term) = (f64_at(&s[..8]), f64_at(&s[8..16]), f64_at(&s[16..]));
        if ![g_max, g_median, rest_term].iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err("a Galerkin scale that is not finite");
        }
        let ne = u64_at(take(8)?);
        let ne = count(ne, 16, bytes.len())?;
        let mut edges = Vec::with_capacity(ne);
        for _ in 0..ne {
            let e = take(16)?;
            let k = u32::from_le_bytes([e[0], e[1], e[2], e[3]]);
            let l = u32::from_le_bytes([e[4], e[5], e[6], e[7]]);
            let w = f64_at(&e[8..]);
            if k as usize >= m || l as usize >= m || !w.is_finite() {
                return Err("a coarse edge out of range");
            }
            edges.push((k, (l, w)));
        }
        if !r.is_empty() {
            return Err("trailing Galerkin bytes");
        }
        let neighbours = Csr::from_pairs(m, &edges);
        let pattern = OnceLock::new();
        Ok(GalerkinMesh { g, pair, g_max, g_median, rest_term, neighbours, sizes: (n, m), pattern })
    }
}
