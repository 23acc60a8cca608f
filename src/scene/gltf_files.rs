//! The bytes of a glTF asset, read only from the asset itself: the `.gltf`
//! or `.glb` file, and the buffers and images it names inside its own
//! folder.
//!
//! The rule (also in `docs/errors.md`): a URI is either a `data:` URI
//! (base64, decoded with a size cap) or a relative path that, after
//! percent-decoding and resolving `..` and symbolic links, stays inside the
//! folder of the glTF file and names a regular file. Absolute paths, other
//! schemes (`file:`, `http:`), escapes and devices or FIFOs are refused
//! naming the URI, before anything is opened. Every size a file states (a
//! GLB's length and chunk lengths, a buffer's `byteLength`, a buffer view's
//! range, an accessor's count, offset and stride) is checked against the
//! bytes that are really there before anything is allocated from it.

use super::confined::confined_path;
use crate::error::FormatError;
use std::borrow::Cow;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest glTF, GLB, buffer or image file plsr reads (bytes).
pub const MAX_FILE_BYTES: u64 = 1 << 32;

/// The most elements an accessor may have (2²⁸: a mesh of 268 million
/// vertices or 89 million triangles).
pub const MAX_ACCESSOR_COUNT: usize = 1 << 28;

/// The most elements of an accessor without a buffer view (all zeros, or
/// only sparse values), whose count no buffer bounds.
pub const MAX_VIEWLESS_COUNT: usize = 1 << 24;

type Result<T> = std::result::Result<T, FormatError>;

/// A glTF document with its buffers loaded.
pub struct GltfAsset {
    /// The parsed document.
    pub doc: gltf::Document,
    /// Each buffer's bytes, exactly `byteLength` of them.
    pub buffers: Vec<Vec<u8>>,
    /// The canonical folder the asset's files must stay in.
    folder: PathBuf,
    /// The buffer files read besides the glTF file itself, for the
    /// scene's identity (images add theirs as they are loaded).
    pub files: Vec<PathBuf>,
}

/// Reads the glTF or GLB file `path` and its buffers, checking every
/// size against what is there (see the module's rule).
pub fn open(path: &Path) -> Result<GltfAsset> {
    let bytes = read_capped(path, MAX_FILE_BYTES, "the file")?;
    if bytes.starts_with(b"glTF") {
        check_glb(&bytes)?;
    }
    let unreadable = |e: gltf::Error| format!("not a readable glTF 2.0 file: {e}");
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(unreadable)?;
    let json = gltf.document.into_json();
    check_position_accessors(&json)?;
    let document = gltf::Document::from_json(json).map_err(unreadable)?;
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let folder = folder.canonicalize()?;
    let mut asset = GltfAsset {
        doc: document,
        buffers: Vec::new(),
        folder,
        files: Vec::new(),
    };
    let mut blob = gltf.blob;
    for b in asset.doc.buffers() {
        let field = format!("buffers[{}]", b.index());
        let length = b.length();
        if length as u64 > MAX_FILE_BYTES {
            return Err(format!("{field}.byteLength {length} is above plsr's limit").into());
        }
        let data = match b.source() {
            gltf::buffer::Source::Bin => {
                let data = blob.take().ok_or_else(|| {
                    format!("{field} is the GLB's binary chunk, but the file has none")
                })?;
                if data.len() < length {
                    return Err(format!(
                        "{field}.byteLength {length} is past the GLB binary chunk's {} bytes",
                        data.len()
                    )
                    .into());
                }
                data
            }
            gltf::buffer::Source::Uri(uri) => {
                let (data, file) =
                    asset.read_uri(uri, &format!("{field}.uri"), length as u64, true)?;
                asset.files.extend(file);
                if data.len() < length {
                    return Err(format!(
                        "{field}.byteLength {length} is past the {} bytes of {uri:?}",
                        data.len()
                    )
                    .into());
                }
                data.into_owned()
            }
        };
        let mut data = data;
        data.truncate(length);
        asset.buffers.push(data);
    }
    asset.check_views_and_accessors()?;
    asset.check_attribute_types()?;
    Ok(asset)
}

/// Every primitive's `POSITION` names an accessor that exists. The glTF
/// crate's validation indexes the accessors with it unchecked (a panic,
/// found by fuzzing), so this runs before it.
fn check_position_accessors(json: &gltf::json::Root) -> Result<()> {
    use gltf::json::validation::Checked;
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = Checked::Valid(gltf::Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&position) {
                if index.value() >= json.accessors.len() {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].attributes.POSITION is accessor {}, \
                         but the file has {} accessors",
                        index.value(),
                        json.accessors.len()
                    )
                    .into());
                }
            }
        }
    }
    Ok(())
}

impl GltfAsset {
    /// The encoded bytes of image `index` (PNG, JPEG, …) from a buffer
    /// view, a `data:` URI or a file in the asset's folder, and that file.
    pub fn image_bytes(&self, index: usize) -> Result<(Cow<'_, [u8]>, Option<PathBuf>)> {
        let image = self
            .doc
            .images()
            .nth(index)
            .ok_or_else(|| format!("images[{index}] does not exist"))?;
        // `source()` unwraps these (found by fuzzing): a view needs its
        // mimeType, and an image needs a view or a URI.
        let json = &self.doc.as_json().images[index];
        if json.buffer_view.is_some() && json.mime_type.is_none() {
            return Err(format!("images[{index}] is in a bufferView, but has no mimeType").into());
        }
        if json.buffer_view.is_none() && json.uri.is_none() {
            return Err(format!("images[{index}] has neither a uri nor a bufferView").into());
        }
        match image.source() {
            gltf::image::Source::View { view, .. } => {
                let buffer = &self.buffers[view.buffer().index()];
                // In range: checked by `check_views_and_accessors`.
                let bytes = &buffer[view.offset()..view.offset() + view.length()];
                Ok((Cow::Borrowed(bytes), None))
            }
            gltf::image::Source::Uri { uri, .. } => {
                self.read_uri(uri, &format!("images[{index}].uri"), MAX_FILE_BYTES, false)
            }
        }
    }

    /// The bytes a URI names (at most `cap`: a file's first `cap` bytes
    /// where `prefix`, else a longer file is refused), and the file it
    /// resolved to (none for a `data:` URI). `field` names the URI in
    /// errors.
    fn read_uri(
        &self,
        uri: &str,
        field: &str,
        cap: u64,
        prefix: bool,
    ) -> Result<(Cow<'static, [u8]>, Option<PathBuf>)> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let data = decode_data_uri(rest, cap).map_err(|m| format!("{field}: {m}"))?;
            return Ok((Cow::Owned(data), None));
        }
        let path = confined_uri(&self.folder, uri).map_err(|m| format!("{field} {uri:?}: {m}"))?;
        let data =
            read_first(&path, cap, uri, prefix).map_err(|e| format!("{field} {uri:?}: {e}"))?;
        Ok((Cow::Owned(data), Some(path)))
    }

    /// Checks every buffer view against its buffer and every accessor
    /// against its view (and its sparse storage), so that reading them
    /// later stays inside the bytes and allocates no more than the file
    /// holds.
    /// Every primitive attribute (and morph target) and index accessor
    /// has a type and component type the glTF specification allows for
    /// it, which is what the reader assumes: the `gltf` crate reads a
    /// `NORMAL` as three floats whatever the accessor says (found by
    /// fuzzing: an accessor of three shorts read as floats).
    fn check_attribute_types(&self) -> Result<()> {
        use gltf::accessor::{DataType as D, Dimensions as N};
        use gltf::Semantic as S;
        let allowed = |semantic: &S| -> (&'static [N], &'static [D], &'static str) {
            match semantic {
                S::Positions | S::Normals => (&[N::Vec3], &[D::F32], "VEC3 of FLOAT"),
                S::Tangents => (&[N::Vec4], &[D::F32], "VEC4 of FLOAT"),
                S::TexCoords(_) => (
                    &[N::Vec2],
                    &[D::F32, D::U8, D::U16],
                    "VEC2 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT",
                ),
                S::Colors(_) => (
                    &[N::Vec3, N::Vec4],
                    &[D::F32, D::U8, D::U16],
                    "VEC3 or VEC4 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT",
                ),
                S::Joints(_) => (
                    &[N::Vec4],
                    &[D::U8, D::U16],
                    "VEC4 of UNSIGNED_BYTE or UNSIGNED_SHORT",
                ),
                S::Weights(_) => (
                    &[N::Vec4],
                    &[D::F32, D::U8, D::U16],
                    "VEC4 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT",
                ),
            }
        };
        let check = |field: String, a: &gltf::Accessor, semantic: &S| -> Result<()> {
            let (dims, types, says) = allowed(semantic);
            if dims.contains(&a.dimensions()) && types.contains(&a.data_type()) {
                return Ok(());
            }
            Err(format!(
                "{field} is accessor {} of {:?} {:?}; glTF requires {says}",
                a.index(),
                a.dimensions(),
                a.data_type()
            )
            .into())
        };
        // Animations (found by fuzzing: a scalar output read as rotations).
        // The glTF crate validates no channel's target: an unknown path or
        // a node out of range would panic where it is read.
        let nodes = self.doc.nodes().len();
        for (a, animation) in self.doc.as_json().animations.iter().enumerate() {
            for (c, channel) in animation.channels.iter().enumerate() {
                let field = format!("animations[{a}].channels[{c}].target");
                if !matches!(
                    channel.target.path,
                    gltf::json::validation::Checked::Valid(_)
                ) {
                    return Err(format!(
                        "{field}.path: not a glTF animation path (translation, rotation, scale \
                         or weights)"
                    )
                    .into());
                }
                if channel.target.node.value() >= nodes {
                    return Err(format!(
                        "{field}.node {} is out of range: the file has {nodes} nodes",
                        channel.target.node.value()
                    )
                    .into());
                }
            }
        }
        for animation in self.doc.animations() {
            for (c, channel) in animation.channels().enumerate() {
                use gltf::animation::Property as P;
                let field = format!("animations[{}].channels[{c}]", animation.index());
                let sampler = channel.sampler();
                let input = sampler.input();
                if input.dimensions() != N::Scalar || input.data_type() != D::F32 {
                    return Err(format!(
                        "{field}: its sampler's input is accessor {} of {:?} {:?}; glTF \
                         requires SCALAR of FLOAT (times in seconds)",
                        input.index(),
                        input.dimensions(),
                        input.data_type()
                    )
                    .into());
                }
                let ints = [D::F32, D::I8, D::U8, D::I16, D::U16];
                let (dims, types, says): (N, &[D], &str) = match channel.target().property() {
                    P::Translation | P::Scale => (N::Vec3, &[D::F32], "VEC3 of FLOAT"),
                    P::Rotation => (N::Vec4, &ints, "VEC4 of FLOAT or normalised integers"),
                    P::MorphTargetWeights => {
                        (N::Scalar, &ints, "SCALAR of FLOAT or normalised integers")
                    }
                };
                let output = sampler.output();
                if output.dimensions() != dims || !types.contains(&output.data_type()) {
                    return Err(format!(
                        "{field}: its sampler's output is accessor {} of {:?} {:?}; glTF \
                         requires {says} for this property",
                        output.index(),
                        output.dimensions(),
                        output.data_type()
                    )
                    .into());
                }
            }
        }
        for mesh in self.doc.meshes() {
            for p in mesh.primitives() {
                let field = format!("meshes[{}].primitives[{}]", mesh.index(), p.index());
                for (semantic, a) in p.attributes() {
                    check(
                        format!("{field}.attributes.{}", semantic.to_string()),
                        &a,
                        &semantic,
                    )?;
                }
                for (t, target) in p.morph_targets().enumerate() {
                    let parts = [
                        (target.positions(), S::Positions, "POSITION"),
                        (target.normals(), S::Normals, "NORMAL"),
                        (target.tangents(), S::Tangents, "TANGENT"),
                    ];
                    for (a, semantic, name) in parts {
                        if let Some(a) = a {
                            check(format!("{field}.targets[{t}].{name}"), &a, &semantic)?;
                        }
                    }
                }
                if let Some(a) = p.indices() {
                    if a.dimensions() != N::Scalar
                        || !matches!(a.data_type(), D::U8 | D::U16 | D::U32)
                    {
                        return Err(format!(
                            "{field}.indices is accessor {} of {:?} {:?}; glTF requires \
                             SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                            a.index(),
                            a.dimensions(),
                            a.data_type()
                        )
                        .into());
                    }
                }
            }
        }
        Ok(())
    }

    fn check_views_and_accessors(&self) -> Result<()> {
        for v in self.doc.views() {
            let field = format!("bufferViews[{}]", v.index());
            let buffer = self.buffers[v.buffer().index()].len();
            let end = v.offset().checked_add(v.length());
            if end.is_none_or(|e| e > buffer) {
                return Err(format!(
                    "{field}: byteOffset {} + byteLength {} is past buffer {}'s {buffer} bytes",
                    v.offset(),
                    v.length(),
                    v.buffer().index()
                )
                .into());
            }
            if let Some(s) = v.stride() {
                if !(4..=252).contains(&s) || s % 4 != 0 {
                    return Err(format!(
                        "{field}.byteStride {s} must be a multiple of 4 in [4, 252]"
                    )
                    .into());
                }
            }
        }
        for a in self.doc.accessors() {
            let field = format!("accessors[{}]", a.index());
            let count = a.count();
            // Found by fuzzing: the glTF crate's reader computes
            // `count - 1`; the format asks for at least one element.
            if count == 0 {
                return Err(
                    format!("{field}.count is 0: an accessor has at least one element").into(),
                );
            }
            if count > MAX_ACCESSOR_COUNT {
                return Err(format!(
                    "{field}.count {count} is above plsr's limit of {MAX_ACCESSOR_COUNT}"
                )
                .into());
            }
            let element = a.size();
            match a.view() {
                Some(view) => {
                    let stride = view.stride().unwrap_or(element);
                    // Found by fuzzing: the reader takes elements of their
                    // own size at each stride, overlapping the next ones.
                    if stride < element {
                        return Err(format!(
                            "{field}: bufferViews[{}].byteStride {stride} is less than \
                             the accessor's elements of {element} bytes",
                            view.index()
                        )
                        .into());
                    }
                    fits(
                        &field,
                        a.offset(),
                        count,
                        stride,
                        element,
                        view.length(),
                        "its buffer view",
                    )?;
                }
                None if count > MAX_VIEWLESS_COUNT => {
                    return Err(format!(
                        "{field}.count {count}: an accessor without a buffer view may have at \
                         most {MAX_VIEWLESS_COUNT} elements"
                    )
                    .into());
                }
                None => {}
            }
            if let Some(sparse) = a.sparse() {
                let n = sparse.count();
                if n > count {
                    return Err(format!(
                        "{field}.sparse.count {n} is more than the accessor's {count}"
                    )
                    .into());
                }
                let indices = sparse.indices();
                let size = match indices.index_type() {
                    gltf::accessor::sparse::IndexType::U8 => 1,
                    gltf::accessor::sparse::IndexType::U16 => 2,
                    gltf::accessor::sparse::IndexType::U32 => 4,
                };
                fits(
                    &format!("{field}.sparse.indices"),
                    indices.offset(),
                    n,
                    size,
                    size,
                    indices.view().length(),
                    "its buffer view",
                )?;
                let values = sparse.values();
                fits(
                    &format!("{field}.sparse.values"),
                    values.offset(),
                    n,
                    element,
                    element,
                    values.view().length(),
                    "its buffer view",
                )?;
            }
        }
        Ok(())
    }
}

/// Checks that `count` elements of `element` bytes, `stride` apart from
/// `offset`, lie within `length` bytes.
fn fits(
    field: &str,
    offset: usize,
    count: usize,
    stride: usize,
    element: usize,
    length: usize,
    what: &str,
) -> Result<()> {
    if count == 0 {
        return Ok(());
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(element))
        .and_then(|x| x.checked_add(offset));
    match end {
        Some(e) if e <= length => Ok(()),
        _ => Err(format!(
            "{field}: {count} elements of {element} bytes, {stride} apart from byte {offset}, \
             run past the {length} bytes of {what}"
        )
        .into()),
    }
}

/// Checks a GLB's header and chunk lengths against the file's size, before
/// the parser sees them.
fn check_glb(bytes: &[u8]) -> Result<()> {
    let word = |at: usize| -> Option<u32> {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err("a GLB file shorter than its 12-byte header".into());
    };
    if version != 2 {
        return Err(format!("GLB version {version}: plsr reads glTF 2.0").into());
    }
    if length as usize > bytes.len() || length < 12 {
        return Err(format!(
            "the GLB header's length {length} does not fit the file's size, {} bytes",
            bytes.len()
        )
        .into());
    }
    // The chunks end where the header's length says, whatever follows.
    let end_of_file = length as usize;
    let mut at = 12usize;
    let mut chunk = 0;
    while at < end_of_file {
        // Found by fuzzing: a chunk header running past the length.
        if at + 8 > end_of_file {
            return Err(format!("GLB chunk {chunk}: its 8-byte header is cut off").into());
        }
        let (Some(len), Some(_kind)) = (word(at), word(at + 4)) else {
            return Err(format!("GLB chunk {chunk}: its 8-byte header is cut off").into());
        };
        let end = (at + 8).checked_add(len as usize);
        if end.is_none_or(|e| e > end_of_file) {
            return Err(format!(
                "GLB chunk {chunk}: length {len} is past the end of the file ({} bytes from \
                 byte {})",
                end_of_file - at - 8,
                at + 8
            )
            .into());
        }
        at = end.expect("checked");
        chunk += 1;
    }
    Ok(())
}

/// `uri` (relative, percent-encoded) resolved inside the canonical folder
/// `folder` ([`confined_path`]); or why not.
fn confined_uri(folder: &Path, uri: &str) -> std::result::Result<PathBuf, String> {
    if let Some(colon) = uri.find(':') {
        let scheme = &uri[..colon];
        if !scheme.is_empty()
            && scheme
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
        {
            return Err(format!(
                "`{scheme}:` URIs are not read: a glTF's files must be relative paths inside its \
                 folder"
            ));
        }
    }
    confined_path(folder, &percent_decode(uri)?, "a glTF's")
}

/// A URI's `%XX` escapes decoded (as UTF-8).
fn percent_decode(uri: &str) -> std::result::Result<String, String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or("a `%` not followed by two hexadecimal digits")?;
            out.push(hex);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| "percent-escapes that are not UTF-8".to_string())
}

/// The payload of a `data:` URI (what follows `data:`): base64 only, at
/// most `cap` bytes once decoded.
fn decode_data_uri(rest: &str, cap: u64) -> std::result::Result<Vec<u8>, String> {
    let (header, payload) = rest
        .split_once(',')
        .ok_or("a data: URI without a `,` before its data")?;
    if !header.ends_with(";base64") {
        return Err("a data: URI must be base64-encoded (`;base64,`)".into());
    }
    let padding = payload.bytes().rev().take(2).filter(|&c| c == b'=').count();
    if (payload.len() - padding) as u64 * 3 / 4 > cap {
        return Err(format!(
            "a data: URI of {} encoded bytes, above the limit of {cap} bytes",
            payload.len()
        ));
    }
    base64_decode(payload.as_bytes())
}

/// Standard base64 (RFC 4648, `=` padding optional) decoded.
fn base64_decode(text: &[u8]) -> std::result::Result<Vec<u8>, String> {
    fn value(c: u8) -> Option<u32> {
        match c {
            b'A'..=b'Z' => Some((c - b'A') as u32),
            b'a'..=b'z' => Some((c - b'a') as u32 + 26),
            b'0'..=b'9' => Some((c - b'0') as u32 + 52),
            b'+' => Some(62),
            b'/' => Some(63),
            _ => None,
        }
    }
    let text = match text.iter().rposition(|&c| c != b'=') {
        Some(last) if text.len() - last - 1 <= 2 => &text[..=last],
        Some(_) => return Err("base64 data with more than two `=`".into()),
        None => &text[..0],
    };
    let mut out = Vec::with_capacity(text.len() / 4 * 3 + 2);
    for (k, group) in text.chunks(4).enumerate() {
        let mut acc = 0u32;
        for (j, &c) in group.iter().enumerate() {
            let v = value(c).ok_or_else(|| {
                format!("base64 data: byte {} ({c:#04x}) is not base64", 4 * k + j)
            })?;
            acc |= v << (18 - 6 * j);
        }
        let n = match group.len() {
            4 => 3,
            3 => 2,
            2 => 1,
            _ => return Err("base64 data of a length that cannot be decoded".into()),
        };
        out.extend_from_slice(&acc.to_be_bytes()[1..1 + n]);
    }
    Ok(out)
}

/// The contents of the regular file `path`, refused above `cap` bytes
/// (`what` names it in that message) before anything is opened (a FIFO
/// would block the open).
fn read_capped(path: &Path, cap: u64, what: &str) -> Result<Vec<u8>> {
    read_first(path, cap, what, false)
}

/// The first `cap` bytes of the regular file `path` where `prefix` (a
/// buffer file longer than its `byteLength`), or the whole file, refused
/// above `cap` bytes.
fn read_first(path: &Path, cap: u64, what: &str, prefix: bool) -> Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(format!("{what} is not a regular file (a folder, device or FIFO)").into());
    }
    if meta.len() > cap && !prefix {
        return Err(format!("{what} is {} bytes, above the limit of {cap}", meta.len()).into());
    }
    let mut data = Vec::with_capacity(meta.len().min(cap) as usize);
    std::fs::File::open(path)?
        .take(cap)
        .read_to_end(&mut data)?;
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_every_length() {
        // Encoded by hand-checked rule: "Man" → "TWFu", "Ma" → "TWE=", "M" → "TQ==".
        assert_eq!(base64_decode(b"TWFu").unwrap(), b"Man");
        assert_eq!(base64_decode(b"TWE=").unwrap(), b"Ma");
        assert_eq!(base64_decode(b"TWE").unwrap(), b"Ma");
        assert_eq!(base64_decode(b"TQ==").unwrap(), b"M");
        assert_eq!(base64_decode(b"").unwrap(), b"");
        assert_eq!(
            base64_decode(b"AAECAwQF/w==").unwrap(),
            [0u8, 1, 2, 3, 4, 5, 255]
        );
        assert!(base64_decode(b"TW@u").unwrap_err().contains("byte 2"));
        assert!(base64_decode(b"T").is_err());
    }

    #[test]
    fn percent_escapes_are_decoded() {
        assert_eq!(percent_decode("a%20b.png").unwrap(), "a b.png");
        assert_eq!(percent_decode("%C3%A9.bin").unwrap(), "é.bin");
        assert!(percent_decode("a%2").is_err());
        assert!(percent_decode("%ff").is_err());
    }

    #[test]
    fn glb_lengths_are_checked_against_the_file() {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(0xFFFF_FFF0u32.to_le_bytes());
        assert!(check_glb(&glb)
            .unwrap_err()
            .to_string()
            .contains("4294967280"));
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(28u32.to_le_bytes());
        glb.extend(0xFFFF_FFF0u32.to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(b"{}\n\n    ");
        let e = check_glb(&glb).unwrap_err().to_string();
        assert!(e.contains("chunk 0") && e.contains("past the end"), "{e}");
    }

    #[test]
    fn element_ranges_must_fit() {
        assert!(fits("a", 0, 3, 12, 12, 36, "v").is_ok());
        assert!(fits("a", 4, 3, 12, 12, 36, "v").is_err());
        assert!(fits("a", 0, 3, 16, 12, 44, "v").is_ok());
        assert!(fits("a", 0, usize::MAX, 16, 12, 44, "v").is_err());
        assert!(fits("a", 0, 0, 16, 12, 0, "v").is_ok());
    }
}
