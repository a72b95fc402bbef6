//! The URIs of a glTF's buffers and images (glTF 2.0 spec §3.6.1.1 "URIs"): base64 `data:`
//! URIs, or relative paths (percent-encoded) to files in the `.gltf`'s folder. Remote and
//! other schemes are refused; a path is resolved by [`super::reference`] and one outside the
//! folder is refused unless the policy allows it.

use super::error::{Ctx, LoadError};
use super::reference::{Folder, resolve};

/// The bytes of a buffer or image URI (`what` names it in messages, e.g. `"buffer 0"`):
/// base64 `data:` URIs, or a file path relative to `folder`'s root.
///
/// Output: `Ok(Ok(bytes))`; `Ok(Err(message))` when the reference is refused (a scheme, no
/// folder to read from, outside the folder): the message names the URI, and the caller
/// decides whether that fails the load (a buffer) or drops the reference (an image).
/// Errors: an invalid data URI, a file that cannot be read. Of a file, at most `limit` bytes are
/// read ([`super::reference::read_file`]).
pub(crate) fn read_uri(
    uri: &str,
    ctx: Ctx,
    folder: Option<Folder>,
    what: &str,
    limit: u64,
) -> Result<Result<Vec<u8>, String>, LoadError> {
    use base64::Engine;
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(ctx.parse(None, format!("{what}: a data URI that is not base64")));
        };
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map(Ok)
            .map_err(|e| ctx.parse(None, format!("{what}: invalid base64 data ({e})")));
    }
    let Some(folder) = folder else {
        return Ok(Err(format!(
            "{what} is an external file ({uri}), which needs the glTF's folder"
        )));
    };
    let resolved = match resolve(folder.root, folder.root, &percent_decode(uri)) {
        Ok(r) => r,
        Err(why) => return Ok(Err(format!("{what} refers to {why}"))),
    };
    if resolved.outside && !folder.policy.allow_outside {
        return Ok(Err(format!(
            "{what} refers to {uri}, outside the glTF's folder; not read (files outside an \
             asset's folder are read only when allowed: --allow-outside-references)"
        )));
    }
    super::reference::read_file(&resolved.path, limit).map(Ok).map_err(|e| {
        ctx.parse(None, format!("{what}: cannot read {}: {e}", resolved.path.display()))
    })
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
        assert_eq!(percent_decode("..%2F..%2fetc%2Fpasswd"), "../../etc/passwd");
    }
}
