//! The bytes of a glTF file's buffers: the GLB binary chunk, a `data:` URI (base64), or a file
//! beside the glTF file. Resolved here rather than by the `gltf` crate's importer so that a
//! missing or short buffer is an error naming `buffers[i]`, and so no image is ever decoded.

use std::path::Path;

use base64::Engine;

use crate::error::ImportError;

/// Every buffer of `document`, in order, each exactly its declared `byteLength` long.
/// `blob` is the GLB binary chunk; `dir` the directory relative URIs are resolved against.
pub fn load_buffers(
    document: &gltf::Document,
    blob: Option<&[u8]>,
    dir: &Path,
) -> Result<Vec<Vec<u8>>, ImportError> {
    document
        .buffers()
        .map(|buffer| {
            let element = format!("buffers[{}]", buffer.index());
            let bytes = match buffer.source() {
                gltf::buffer::Source::Bin => blob.map(<[u8]>::to_vec).ok_or_else(|| {
                    ImportError::new(
                        &element,
                        "refers to the GLB binary chunk, which the file does not have",
                    )
                })?,
                gltf::buffer::Source::Uri(uri) => read_uri(uri, dir, &element)?,
            };
            let length = buffer.length();
            if bytes.len() < length {
                return Err(ImportError::new(
                    &element,
                    format!(
                        "byteLength is {length} but the data has only {} bytes",
                        bytes.len()
                    ),
                ));
            }
            // A GLB chunk is padded to four bytes; the buffer is its first byteLength bytes.
            Ok(bytes[..length].to_vec())
        })
        .collect()
}

/// A buffer's URI: `data:…;base64,…` or a relative path (percent-escapes decoded).
fn read_uri(uri: &str, dir: &Path, element: &str) -> Result<Vec<u8>, ImportError> {
    if let Some(data) = uri.strip_prefix("data:") {
        let Some((_, payload)) = data.split_once(";base64,") else {
            return Err(ImportError::new(
                format!("{element}.uri"),
                "a data URI must be base64 (data:…;base64,…)",
            ));
        };
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| ImportError::new(format!("{element}.uri"), format!("bad base64: {e}")));
    }
    if uri.contains("://") {
        return Err(ImportError::new(
            format!("{element}.uri"),
            format!("{uri:?}: only files beside the glTF file and data URIs are read"),
        ));
    }
    let relative = percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| ImportError::new(format!("{element}.uri"), "not UTF-8 once unescaped"))?;
    let file = dir.join(relative.as_ref());
    std::fs::read(&file)
        .map_err(|e| ImportError::new(element, format!("cannot read {} ({e})", file.display())))
}
