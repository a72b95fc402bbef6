//! The URIs of a glTF's buffers and images (glTF 2.0 spec §3.6.1.1 "URIs"): base64 `data:`
//! URIs, or relative paths (percent-encoded) to files beside the `.gltf`; remote URIs are
//! refused.

use std::path::Path;

use super::error::{Ctx, LoadError};

/// The bytes of a buffer or image URI (`what` names it in errors, e.g. `"buffer 0"`): base64
/// `data:` URIs, or a file path relative to `dir`.
pub(crate) fn read_uri(
    uri: &str,
    ctx: Ctx,
    dir: Option<&Path>,
    what: &str,
) -> Result<Vec<u8>, LoadError> {
    use base64::Engine;
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(ctx.parse(None, format!("{what}: a data URI that is not base64")));
        };
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| ctx.parse(None, format!("{what}: invalid base64 data ({e})")));
    }
    if uri.contains("://") {
        return Err(ctx.unsupported(format!("{what} refers to a remote URI ({uri})")));
    }
    let Some(dir) = dir else {
        return Err(ctx.unsupported(format!(
            "{what} is an external file ({uri}), which needs the glTF's folder"
        )));
    };
    let path = dir.join(percent_decode(uri));
    std::fs::read(&path)
        .map_err(|e| ctx.parse(None, format!("{what}: cannot read {}: {e}", path.display())))
}

/// `%XX` escapes in a relative URI decoded (a file name with spaces is written `%20`).
pub(crate) fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
        match (bytes[i], hex.and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(b)) => {
                out.push(b);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_decode_and_malformed_ones_stay() {
        assert_eq!(percent_decode("my%20texture.png"), "my texture.png");
        assert_eq!(percent_decode("a%2"), "a%2");
        assert_eq!(percent_decode("%zz%41"), "%zzA");
    }
}
