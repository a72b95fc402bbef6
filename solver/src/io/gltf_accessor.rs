//! Decoding a glTF primitive's accessors (for `gltf`): each element's components as `f64`
//! after its byte range is checked against its buffer view and buffer, so that no file makes
//! the reader panic; normalized integers by the glTF rule ([`component`]); vertex attributes
//! checked against what the reader supports ([`Spec`], [`attribute`]).

use std::sync::Arc;

use ::gltf::accessor::{DataType, Dimensions};

use super::error::{Ctx, LoadError};

/// What [`attribute`] reads: the semantic, its name in messages, the allowed dimensions,
/// the allowed component types (with whether each is normalized; floats as `false`), and the
/// neutral value (RGBA-padded).
pub(super) struct Spec<'a> {
    pub(super) semantic: ::gltf::Semantic,
    pub(super) name: &'a str,
    pub(super) dims: &'a [Dimensions],
    pub(super) types: &'a [(DataType, bool)],
    pub(super) neutral: [f32; 4],
}

/// Component types of normals: float, then (`KHR_mesh_quantization`) normalized 8/16-bit
/// signed.
pub(super) const NORMAL_TYPES: [(DataType, bool); 3] =
    [(DataType::F32, false), (DataType::I8, true), (DataType::I16, true)];

/// Component types of texture coordinates: float and normalized unsigned 8/16-bit, then (with
/// `KHR_mesh_quantization`) 8/16-bit integers signed or not, normalized or not.
pub(super) const UV_TYPES: [(DataType, bool); 9] = [
    (DataType::F32, false),
    (DataType::U8, true),
    (DataType::U16, true),
    (DataType::I8, true),
    (DataType::I16, true),
    (DataType::U8, false),
    (DataType::U16, false),
    (DataType::I8, false),
    (DataType::I16, false),
];

/// Component types of colours: float or normalized unsigned 8/16-bit.
pub(super) const COLOR_TYPES: [(DataType, bool); 3] =
    [(DataType::F32, false), (DataType::U8, true), (DataType::U16, true)];

/// The value of a stored component `c` (its integer value for integer types) of type `dt`:
/// itself for floats and unnormalized integers; for a normalized one, $c/(2^b-1)$ unsigned and
/// $\max(c/(2^{b-1}-1), -1)$ signed (the glTF 2.0 specification's rule for normalized
/// integers).
pub(super) fn component(dt: DataType, normalized: bool, c: f64) -> f64 {
    if !normalized {
        return c;
    }
    match dt {
        DataType::U8 => c / 255.0,
        DataType::U16 => c / 65535.0,
        DataType::U32 => c / 4294967295.0,
        DataType::I8 => (c / 127.0).max(-1.0),
        DataType::I16 => (c / 32767.0).max(-1.0),
        DataType::F32 => c,
    }
}

/// One vertex attribute of a primitive as RGBA-padded `f32` (missing components: 0, except
/// alpha 1 for an RGB colour), or `None` when the primitive has none.
///
/// Checks: dimensions among `spec.dims`; component type and normalization among
/// `spec.types`, decoded by [`component`]; exactly `n` elements, like POSITION. Any failure is
/// a one-line error naming the accessor. An element with a non-finite value (exporters write
/// NaN normals for degenerate triangles) is replaced by `spec.neutral`, with a line in
/// `notices`.
pub(super) fn attribute(
    prim: &::gltf::Primitive,
    spec: &Spec,
    n: usize,
    (buffers, ctx): (&[Arc<[u8]>], Ctx),
    notices: &mut Vec<String>,
) -> Result<Option<Vec<[f32; 4]>>, LoadError> {
    let Some(acc) = prim.get(&spec.semantic) else { return Ok(None) };
    let name = spec.name;
    let (dt, dim, normalized) = (acc.data_type(), acc.dimensions(), acc.normalized());
    if !spec.types.contains(&(dt, normalized && dt != DataType::F32)) {
        let allowed: Vec<String> = spec
            .types
            .iter()
            .map(|(t, n)| format!("{t:?}{}", if *n { " normalized" } else { "" }))
            .collect();
        return Err(ctx.unsupported(format!(
            "{name} accessor {} is {dt:?}{}; supported: {}",
            acc.index(),
            if normalized { " normalized" } else { "" },
            allowed.join(", ")
        )));
    }
    if !spec.dims.contains(&dim) {
        return Err(ctx.parse(
            None,
            format!("{name} accessor {} is {dim:?}, expected {:?}", acc.index(), spec.dims),
        ));
    }
    if acc.count() != n {
        return Err(ctx.count(
            None,
            format!(
                "{name} accessor {} has {} elements but primitive {} has {n} vertices",
                acc.index(),
                acc.count(),
                prim.index()
            ),
        ));
    }
    let mut out = Vec::with_capacity(n);
    let mut bad = 0;
    read_accessor(&acc, buffers, ctx, |c| {
        let mut v = c.map(|x| component(dt, normalized, x) as f32);
        if dim == Dimensions::Vec3 && spec.semantic == ::gltf::Semantic::Colors(0) {
            v[3] = 1.0;
        }
        if v.iter().any(|x| !x.is_finite()) {
            bad += 1;
            v = spec.neutral;
        }
        out.push(v);
    })?;
    if bad > 0 {
        notices.push(format!(
            "{}: {name} accessor {}: {bad} of {n} elements are not finite; read as {:?}",
            ctx.file,
            acc.index(),
            &spec.neutral[..dim.multiplicity().min(4)]
        ));
    }
    Ok(Some(out))
}

/// Calls `f` with each element of a float or unsigned-integer accessor (components as `f64`,
/// up to four), after checking the accessor's byte range against its buffer view and buffer.
pub(super) fn read_accessor(
    acc: &::gltf::Accessor,
    buffers: &[Arc<[u8]>],
    ctx: Ctx,
    mut f: impl FnMut([f64; 4]),
) -> Result<(), LoadError> {
    if acc.sparse().is_some() {
        return Err(ctx.unsupported(format!(
            "accessor {} is sparse, which this reader does not support",
            acc.index()
        )));
    }
    let Some(view) = acc.view() else {
        return Err(ctx.parse(None, format!("accessor {} has no buffer view", acc.index())));
    };
    let comp = acc.data_type().size();
    let dims = acc.dimensions().multiplicity();
    if dims > 4 {
        return Err(ctx.parse(None, format!("accessor {} is a matrix", acc.index())));
    }
    let elem = comp * dims;
    let stride = view.stride().unwrap_or(elem);
    let count = acc.count();
    let range_error = || {
        ctx.truncated(None, format!("accessor {} reaches past the end of its buffer", acc.index()))
    };
    let buffer = buffers.get(view.buffer().index()).ok_or_else(range_error)?;
    let view_end = view.offset().checked_add(view.length()).ok_or_else(range_error)?;
    let data = buffer.get(view.offset()..view_end).ok_or_else(range_error)?;
    if stride < elem {
        return Err(
            ctx.parse(None, format!("accessor {}: byte stride below its size", acc.index()))
        );
    }
    if count > 0 {
        let last = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(acc.offset()))
            .and_then(|x| x.checked_add(elem))
            .ok_or_else(range_error)?;
        if last > data.len() {
            return Err(range_error());
        }
    }
    let dt = acc.data_type();
    for k in 0..count {
        let at = acc.offset() + k * stride;
        let mut c = [0.0; 4];
        for (d, value) in c.iter_mut().enumerate().take(dims) {
            let o = at + d * comp;
            let b = &data[o..o + comp];
            *value = match dt {
                DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                DataType::U8 => f64::from(b[0]),
                DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                DataType::I8 => f64::from(b[0] as i8),
            };
        }
        f(c);
    }
    Ok(())
}
