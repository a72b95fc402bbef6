//! Morph-target storage: one target attribute (VEC3 per vertex) as dense or sparse data.
//!
//! - **Dense**: one buffer view of `count` elements; f32 elements are 12 bytes, normalized
//!   i16 elements are padded to a stride of 8 and normalized i8 elements to a stride of 4
//!   (glTF: vertex attribute elements start on 4-byte boundaries).
//! - **Sparse** (glTF 2.0 §3.6.2.3): an accessor without a buffer view (all zeros) whose
//!   `sparse` lists the `m` vertices with a nonzero delta: indices (u16, or u32 past 65 536
//!   vertices) and tightly packed values, each view padded to 4 bytes. Chosen when the file
//!   gets smaller: $\lceil m\,b_i\rceil_4 + \lceil m\,b_e\rceil_4 + J < \text{dense size}$,
//!   where $J$ = [`SPARSE_JSON_BYTES`] bounds the JSON a sparse accessor adds (one more view
//!   and the `sparse` object).
//!   When no vertex moves, the sparse list holds vertex 0 with its zero value: the spec would
//!   allow an accessor with neither buffer view nor `sparse`, but the `gltf` crate (and so
//!   Bevy and our own reader) rejects one.
//!
//! Sparse storage is used only when the settings allow it.

/// Upper bound of the JSON bytes a sparse accessor adds over a dense one.
pub(super) const SPARSE_JSON_BYTES: usize = 192;

use super::Encoding;

/// A target attribute's values, as they will be stored.
#[derive(Debug)]
pub(super) enum Values {
    F32(Vec<[f32; 3]>),
    /// Normalized SHORT: the reader divides by 32767.
    I16(Vec<[i16; 3]>),
    /// Normalized BYTE: the reader divides by 127.
    I8(Vec<[i8; 3]>),
}

/// How an encoded target is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Storage {
    Dense,
    /// `count` vertices, indices of `index_bytes` (2 or 4) each.
    Sparse {
        count: usize,
        index_bytes: usize,
    },
}

/// An encoded target: its storage, the bytes of its views (dense: one; sparse: indices then
/// values; zero: none) and the min/max of its values (as stored: i16 as integers).
#[derive(Debug)]
pub(super) struct Encoded {
    pub storage: Storage,
    pub views: Vec<Vec<u8>>,
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Values {
    fn len(&self) -> usize {
        match self {
            Values::F32(v) => v.len(),
            Values::I16(v) => v.len(),
            Values::I8(v) => v.len(),
        }
    }

    fn is_zero(&self, i: usize) -> bool {
        match self {
            Values::F32(v) => v[i].iter().all(|&c| c == 0.0),
            Values::I16(v) => v[i].iter().all(|&c| c == 0),
            Values::I8(v) => v[i].iter().all(|&c| c == 0),
        }
    }

    fn get(&self, i: usize) -> [f64; 3] {
        match self {
            Values::F32(v) => v[i].map(f64::from),
            Values::I16(v) => v[i].map(f64::from),
            Values::I8(v) => v[i].map(f64::from),
        }
    }

    /// Bytes of one tightly packed element.
    fn element_bytes(&self) -> usize {
        match self {
            Values::F32(_) => 12,
            Values::I16(_) => 6,
            Values::I8(_) => 3,
        }
    }

    /// The byte stride of a dense view (`None`: tightly packed).
    pub fn dense_stride(&self) -> Option<usize> {
        match self {
            Values::F32(_) => None,
            Values::I16(_) => Some(8),
            Values::I8(_) => Some(4),
        }
    }

    fn push(&self, i: usize, out: &mut Vec<u8>) {
        match self {
            Values::F32(v) => v[i].iter().for_each(|c| out.extend_from_slice(&c.to_le_bytes())),
            Values::I16(v) => v[i].iter().for_each(|c| out.extend_from_slice(&c.to_le_bytes())),
            Values::I8(v) => v[i].iter().for_each(|c| out.extend_from_slice(&c.to_le_bytes())),
        }
    }
}

/// Encodes `values` (dense when `sparse` is false; see the module doc).
pub(super) fn encode(values: &Values, sparse: bool) -> Encoded {
    let n = values.len();
    let mut min = [0.0f64; 3];
    let mut max = [0.0f64; 3];
    if n > 0 {
        min = [f64::INFINITY; 3];
        max = [f64::NEG_INFINITY; 3];
    }
    let mut moving = Vec::new();
    for i in 0..n {
        let v = values.get(i);
        for d in 0..3 {
            min[d] = min[d].min(v[d]);
            max[d] = max[d].max(v[d]);
        }
        if !values.is_zero(i) {
            moving.push(i as u32);
        }
    }
    let stride = values.dense_stride().unwrap_or(values.element_bytes());
    let dense_size = n * stride;
    let index_bytes = if n <= 1 << 16 { 2 } else { 4 };
    if moving.is_empty() && n > 0 {
        moving.push(0);
    }
    let m = moving.len();
    let sparse_size =
        (m * index_bytes).next_multiple_of(4) + (m * values.element_bytes()).next_multiple_of(4);
    if sparse && sparse_size + SPARSE_JSON_BYTES < dense_size {
        let mut indices = Vec::with_capacity(m * index_bytes);
        let mut data = Vec::with_capacity(m * values.element_bytes());
        for &i in &moving {
            if index_bytes == 2 {
                indices.extend_from_slice(&(i as u16).to_le_bytes());
            } else {
                indices.extend_from_slice(&i.to_le_bytes());
            }
            values.push(i as usize, &mut data);
        }
        return Encoded {
            storage: Storage::Sparse { count: m, index_bytes },
            views: vec![indices, data],
            min,
            max,
        };
    }
    let mut data = Vec::with_capacity(dense_size);
    for i in 0..n {
        values.push(i, &mut data);
        data.resize(data.len().next_multiple_of(stride), 0);
    }
    Encoded { storage: Storage::Dense, views: vec![data], min, max }
}

/// The stored quantization scale of one mesh in one frame: the smallest f32
/// $s \ge \max|\Delta|$ (0 when nothing moves measurably).
pub(super) fn quantization_scale(max_abs: f64) -> f32 {
    if max_abs < 1e-30 {
        return 0.0;
    }
    let mut s = max_abs as f32;
    if (s as f64) < max_abs {
        s = f32::from_bits(s.to_bits() + 1);
    }
    s
}

/// The stored values of one mesh in one frame (equations in `mod.rs`'s doc): its animation
/// weight and, per primitive, the POSITION values and (when given) the NORMAL values, from the
/// f64 deltas of every primitive.
///
/// `Float`: weight 1, f32 deltas. `Quantized`: with $s = \max|\Delta|$ and
/// $s_n = \max|\Delta n|$ over the mesh and $k$ its node scale, weight $w = \max(s / k, s_n)$
/// when that is at most 1, positions $\mathrm{round}(32767\,\Delta/(w k))$ as normalized i16 and
/// normals $\mathrm{round}(127\,\Delta n / w)$ as normalized i8; else (a normal delta
/// component above 1: a normal turned by more than about 60°) $w = s / k$ and normals
/// $\Delta n / w$ as f32.
///
/// `min_step` $h \ge 0$ (world units; 0 for none) coarsens the position grid for a compressor
/// (`meshopt.rs`): when the mesh moves ($s > 0$) the position weight $s / k$ is raised to
/// $\min(1, 32767\,h / k)$, so the stored step $w k / 32767$ is $h$ unless that would take $w$
/// past 1 (the normals' step $w / 127$ never exceeds the default's worst case): smaller
/// integers, position error at most $\max(h, s / 32767) / 2$.
pub(super) fn store_mesh_frame(
    encoding: Encoding,
    node_scale: f32,
    min_step: f64,
    deltas: &[Vec<[f64; 3]>],
    normal_deltas: &[Option<Vec<[f64; 3]>>],
) -> (f32, Vec<(Values, Option<Values>)>) {
    let f32s = |d: &[[f64; 3]], s: f64| -> Values {
        Values::F32(
            d.iter().map(|v| v.map(|x| if s == 0.0 { 0.0 } else { (x / s) as f32 })).collect(),
        )
    };
    match encoding {
        Encoding::Float => {
            let stored = deltas
                .iter()
                .zip(normal_deltas)
                .map(|(d, n)| (f32s(d, 1.0), n.as_deref().map(|n| f32s(n, 1.0))))
                .collect();
            (1.0, stored)
        }
        Encoding::Quantized => {
            let max_abs = |d: &mut dyn Iterator<Item = &[f64; 3]>| {
                d.flatten().fold(0.0f64, |m, x| m.max(x.abs()))
            };
            let s = quantization_scale(max_abs(&mut deltas.iter().flatten()));
            let s_n = quantization_scale(max_abs(&mut normal_deltas.iter().flatten().flatten()));
            // `s / node_scale` is exact (a power of two), so `w * node_scale` ≥ s.
            let w_p = s / node_scale;
            let w_p = match s > 0.0 && min_step > 0.0 {
                true => {
                    w_p.max(quantization_scale((32767.0 * min_step / node_scale as f64).min(1.0)))
                }
                false => w_p,
            };
            let bytes = w_p.max(s_n) <= 1.0;
            let w = if bytes { w_p.max(s_n) } else { w_p };
            let scale = w as f64 * node_scale as f64;
            let q = |x: f64| -> i16 {
                if scale == 0.0 {
                    0
                } else {
                    (x / scale * 32767.0).round().clamp(-32767.0, 32767.0) as i16
                }
            };
            let qn = |x: f64| -> i8 {
                if w == 0.0 { 0 } else { (x / w as f64 * 127.0).round().clamp(-127.0, 127.0) as i8 }
            };
            let stored = deltas
                .iter()
                .zip(normal_deltas)
                .map(|(d, n)| {
                    let p = Values::I16(d.iter().map(|v| v.map(q)).collect());
                    let n = n.as_deref().map(|n| match bytes {
                        true => Values::I8(n.iter().map(|v| v.map(qn)).collect()),
                        false => f32s(n, w as f64),
                    });
                    (p, n)
                })
                .collect();
            (w, stored)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sparse_only_when_smaller() {
        let mut v = vec![[0i16; 3]; 200];
        v[7] = [1, -2, 3];
        let e = encode(&Values::I16(v.clone()), true);
        assert_eq!(e.storage, Storage::Sparse { count: 1, index_bytes: 2 });
        assert_eq!(e.views[0], 7u16.to_le_bytes());
        assert_eq!((e.min, e.max), ([0.0, -2.0, 0.0], [1.0, 0.0, 3.0]));
        let e = encode(&Values::I16(v.clone()), false);
        assert_eq!(e.storage, Storage::Dense);
        assert_eq!(e.views[0].len(), 1600);
        assert_eq!(&e.views[0][56..64], &[1, 0, 254, 255, 3, 0, 0, 0]);
        for x in v.iter_mut() {
            *x = [1, 1, 1];
        }
        assert_eq!(encode(&Values::I16(v), true).storage, Storage::Dense);
        let e = encode(&Values::F32(vec![[0.0; 3]; 100]), true);
        assert_eq!(e.storage, Storage::Sparse { count: 1, index_bytes: 2 });
        assert_eq!((e.views[0].as_slice(), e.views[1].as_slice()), (&[0u8, 0][..], &[0u8; 12][..]));
    }

    #[test]
    fn quantized_values_meet_the_error_bound() {
        let d = vec![vec![[0.3, -0.7, 1e-9], [0.0, 0.123_456_789, -0.5]], vec![[0.25, 0.0, 0.0]]];
        let n = vec![None, Some(vec![[0.5; 3], [0.0; 3]])];
        let (s, stored) = store_mesh_frame(Encoding::Quantized, 1.0, 0.0, &d, &n);
        assert!(s as f64 >= 0.7 && (s as f64) < 0.7 * (1.0 + 1e-6));
        for (deltas, (p, _)) in d.iter().zip(&stored) {
            let Values::I16(q) = p else { panic!("not i16") };
            for (v, q) in deltas.iter().zip(q) {
                for k in 0..3 {
                    let got = s as f64 * q[k] as f64 / 32767.0;
                    assert!((got - v[k]).abs() <= s as f64 / 65534.0, "{got} vs {}", v[k]);
                }
            }
        }
        let Some(Values::I8(nv)) = &stored[1].1 else { panic!("normals missing") };
        assert!((nv[0][0] as f32 / 127.0 * s - 0.5).abs() <= s / 254.0);
        let (s, stored) =
            store_mesh_frame(Encoding::Quantized, 1.0, 0.0, &[vec![[0.0; 3]]], &[None]);
        assert_eq!(s, 0.0);
        assert!(matches!(&stored[0].0, Values::I16(q) if q[0] == [0; 3]));
        let (s, _) = store_mesh_frame(Encoding::Float, 1.0, 0.0, &d, &n);
        assert_eq!(s, 1.0);
    }

    #[test]
    fn min_step_raises_the_weight_up_to_one() {
        let d = vec![vec![[1e-3, -2e-4, 0.0], [0.0; 3]]];
        let n = vec![Some(vec![[0.01, 0.0, 0.0], [0.0; 3]])];
        // A grid of 1e-6: the weight becomes 32767e-6 (above s = 1e-3), the step 1e-6.
        let (w, stored) = store_mesh_frame(Encoding::Quantized, 1.0, 1e-6, &d, &n);
        assert!((w as f64 - 0.032767).abs() < 1e-7, "{w}");
        let Values::I16(p) = &stored[0].0 else { panic!("not i16") };
        assert_eq!(p[0], [1000, -200, 0]);
        // A grid that would need a weight above 1 stops at 1; nothing moving stays at 0.
        assert_eq!(store_mesh_frame(Encoding::Quantized, 1.0, 1.0, &d, &n).0, 1.0);
        let still = store_mesh_frame(Encoding::Quantized, 1.0, 1e-6, &[vec![[0.0; 3]]], &[None]);
        assert_eq!(still.0, 0.0);
    }

    #[test]
    fn normals_set_the_weight_and_position_precision_follows_it() {
        // Positions barely move, a normal turns by 37°: the weight is the normals' scale, the
        // positions' error stays within w k / 65534, the normals' within w / 254.
        let d = vec![vec![[1e-3, 0.0, -2e-4], [0.0; 3]]];
        let n = vec![Some(vec![[0.6, 0.0, -0.2], [0.0; 3]])];
        let (w, stored) = store_mesh_frame(Encoding::Quantized, 1.0, 0.0, &d, &n);
        assert!((w as f64 - 0.6).abs() < 1e-6, "{w}");
        let (Values::I16(p), Some(Values::I8(nq))) = (&stored[0].0, &stored[0].1) else {
            panic!("not i16 positions and i8 normals")
        };
        for k in 0..3 {
            let got = w as f64 * p[0][k] as f64 / 32767.0;
            assert!((got - d[0][0][k]).abs() <= w as f64 / 65534.0 + 1e-12);
            let got = w as f64 * nq[0][k] as f64 / 127.0;
            assert!((got - n[0].as_ref().unwrap()[0][k]).abs() <= w as f64 / 254.0 + 1e-9);
        }
        assert_eq!(nq[1], [0; 3]);
        // A normal turned around (delta component 1.6 > 1): f32 normals, weight s / k.
        let n = vec![Some(vec![[0.6, 0.0, -1.6], [0.0; 3]])];
        let (w, stored) = store_mesh_frame(Encoding::Quantized, 1.0, 0.0, &d, &n);
        assert!((w as f64 - 1e-3).abs() < 1e-9, "{w}");
        let Some(Values::F32(nf)) = &stored[0].1 else { panic!("not f32 normals") };
        assert!((nf[0][2] as f64 * w as f64 + 1.6).abs() < 1e-6);
    }
}
