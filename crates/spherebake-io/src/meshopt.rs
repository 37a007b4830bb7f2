//! Decoders for the meshoptimizer bitstreams of `EXT_meshopt_compression` /
//! `KHR_meshopt_compression` (pure Rust, no C library), written from the bitstream description
//! in the `KHR_meshopt_compression` specification (Appendix A "Bitstream", Appendix B "Filters"),
//! whose version-0 attribute format is the `EXT_meshopt_compression` format:
//!
//! - mode `ATTRIBUTES`: [`decode_vertex_buffer`] (attribute codec versions 0 and 1),
//! - mode `TRIANGLES`: [`decode_index_buffer`] (index codec versions 0 and 1),
//! - mode `INDICES`: [`decode_index_sequence`],
//! - filters `OCTAHEDRAL`, `QUATERNION`, `EXPONENTIAL` and `COLOR`: [`apply_filter`].
//!
//! Every decoder checks every read against the input length and the stream structure (header,
//! exact consumption of the data before the tail): malformed input gives a [`MeshoptError`],
//! never a panic, and output allocation is bounded by what the input can encode.

/// Why a meshopt stream could not be decoded.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshoptError {
    /// The stream ends before `what` could be read.
    #[error("stream truncated: {what} needs {needed} bytes at offset {offset}, {available} available")]
    Truncated { what: &'static str, offset: usize, needed: usize, available: usize },
    /// The first byte is not a header of the expected codec.
    #[error("header byte 0x{found:02x} is not a {codec} header (expected 0x{expected:02x})")]
    BadHeader { codec: &'static str, found: u8, expected: u8 },
    /// The codec version in the header is newer than this decoder knows.
    #[error("{codec} version {version} is not supported (versions 0..={max})")]
    UnsupportedVersion { codec: &'static str, version: u8, max: u8 },
    /// Bytes left over between the decoded data and the tail block.
    #[error("{extra} unread bytes before the tail block (decoding stopped at offset {offset})")]
    TrailingData { offset: usize, extra: usize },
    /// Parameters (stride, count, filter) that the format does not allow.
    #[error("invalid parameters: {0}")]
    Parameters(String),
    /// The stream is structurally invalid.
    #[error("malformed stream: {0}")]
    Malformed(String),
}

/// Largest ratio of decoded to encoded bytes the attribute codec can reach (a version-1 block of
/// 256 elements whose bytes are all "zero" control mode stores one control byte per 4 bytes of
/// stride: 1024 output bytes per input byte). Larger claims are refused before allocating.
const MAX_EXPANSION: usize = 1024;

/// Post-decode filter of an `ATTRIBUTES` stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
    Color,
}

impl Filter {
    /// Parses the glTF `filter` string (`None` for an unknown name).
    pub fn from_name(s: &str) -> Option<Filter> {
        Some(match s {
            "NONE" => Filter::None,
            "OCTAHEDRAL" => Filter::Octahedral,
            "QUATERNION" => Filter::Quaternion,
            "EXPONENTIAL" => Filter::Exponential,
            "COLOR" => Filter::Color,
            _ => return None,
        })
    }
}

/// Bounds-checked forward reader over a byte slice.
struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], MeshoptError> {
        let available = self.data.len() - self.pos;
        if n > available {
            return Err(MeshoptError::Truncated { what, offset: self.pos, needed: n, available });
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn byte(&mut self, what: &'static str) -> Result<u8, MeshoptError> {
        Ok(self.take(1, what)?[0])
    }

    /// Unsigned LEB128 with at most 5 bytes (the 5th byte's continuation bit is ignored).
    fn vbyte(&mut self) -> Result<u32, MeshoptError> {
        let lead = self.byte("varint")?;
        if lead < 128 {
            return Ok(u32::from(lead));
        }
        let mut result = u32::from(lead & 127);
        let mut shift = 7;
        for _ in 0..4 {
            let group = self.byte("varint")?;
            result |= u32::from(group & 127) << shift;
            shift += 7;
            if group < 128 {
                break;
            }
        }
        Ok(result)
    }

    fn finish(&self) -> Result<(), MeshoptError> {
        if self.pos == self.data.len() {
            Ok(())
        } else {
            Err(MeshoptError::TrailingData { offset: self.pos, extra: self.data.len() - self.pos })
        }
    }
}

fn unzigzag8(v: u8) -> u8 {
    (0u8.wrapping_sub(v & 1)) ^ (v >> 1)
}

fn unzigzag16(v: u16) -> u16 {
    (0u16.wrapping_sub(v & 1)) ^ (v >> 1)
}

fn unzigzag32(v: u32) -> u32 {
    (0u32.wrapping_sub(v & 1)) ^ (v >> 1)
}

/// Elements per attribute block: `min((8192 / stride) & !15, 256)`.
fn vertex_block_elements(stride: usize) -> usize {
    ((8192 / stride) & !15).min(256)
}

/// Decodes one group of 16 deltas stored with `bits` bits per delta (sentinel encoding).
fn decode_group(r: &mut Reader, out: &mut [u8], bits: u32) -> Result<(), MeshoptError> {
    match bits {
        0 => out.fill(0),
        8 => out.copy_from_slice(r.take(16, "byte group")?),
        1 | 2 | 4 => {
            let per_byte = 8 / bits as usize;
            let sel = r.take(16 / per_byte, "byte group selectors")?;
            let sentinel = (1u8 << bits) - 1;
            for (i, o) in out.iter_mut().enumerate() {
                let byte = sel[i / per_byte];
                let slot = (i % per_byte) as u32;
                // 1-bit deltas are packed from the least significant bit, 2- and 4-bit ones from
                // the most significant.
                let enc = if bits == 1 { (byte >> slot) & 1 } else { (byte >> (8 - bits * (slot + 1))) & sentinel };
                *o = if enc == sentinel { r.byte("byte group sentinel value")? } else { enc };
            }
        }
        _ => unreachable!("bit widths come from fixed tables"),
    }
    Ok(())
}

/// Decodes the deltas of one byte position of a block: header bits, then groups.
fn decode_bytes(r: &mut Reader, out: &mut [u8], bits: &[u32; 4]) -> Result<(), MeshoptError> {
    let groups = out.len() / 16;
    let header = r.take(groups.div_ceil(4), "byte group header")?;
    for g in 0..groups {
        let k = (header[g / 4] >> ((g % 4) * 2)) & 3;
        decode_group(r, &mut out[g * 16..g * 16 + 16], bits[k as usize])?;
    }
    Ok(())
}

/// Decodes an `ATTRIBUTES` stream (`meshopt_decodeVertexBuffer`, versions 0 and 1) of `count`
/// elements of `stride` bytes.
pub fn decode_vertex_buffer(count: usize, stride: usize, data: &[u8]) -> Result<Vec<u8>, MeshoptError> {
    if stride == 0 || stride > 256 || stride % 4 != 0 {
        return Err(MeshoptError::Parameters(format!("byteStride {stride} must be a multiple of 4 in 4..=256")));
    }
    let Some(&header) = data.first() else {
        return Err(MeshoptError::Truncated { what: "header", offset: 0, needed: 1, available: 0 });
    };
    if header & 0xf0 != 0xa0 {
        return Err(MeshoptError::BadHeader { codec: "attribute", found: header, expected: 0xa0 });
    }
    let version = header & 0x0f;
    if version > 1 {
        return Err(MeshoptError::UnsupportedVersion { codec: "attribute codec", version, max: 1 });
    }
    let tail_size = stride + if version == 0 { 0 } else { stride / 4 };
    let tail_pad = tail_size.max(if version == 0 { 32 } else { 24 });
    if data.len() - 1 < tail_pad {
        return Err(MeshoptError::Truncated {
            what: "tail block",
            offset: 1,
            needed: tail_pad,
            available: data.len() - 1,
        });
    }
    let body_end = data.len() - tail_pad;
    let tail = &data[data.len() - tail_size..];
    let mut last = tail[..stride].to_vec();
    let channels = &tail[stride..];
    for (c, &ch) in channels.iter().enumerate() {
        let mode = ch & 0x0f;
        if mode >= 3 || (mode < 2 && ch >> 4 != 0) {
            return Err(MeshoptError::Malformed(format!("channel {c} has invalid mode byte 0x{ch:02x}")));
        }
    }
    let total =
        count.checked_mul(stride).filter(|&t| t <= data.len().saturating_mul(MAX_EXPANSION)).ok_or_else(|| {
            MeshoptError::Parameters(format!(
                "{count} elements of {stride} bytes cannot be encoded in {} bytes",
                data.len()
            ))
        })?;
    let mut out = vec![0u8; total];
    let mut r = Reader { data: &data[..body_end], pos: 1 };
    let block = vertex_block_elements(stride);
    let mut planes = [0u8; 256 * 4];
    let mut start = 0;
    while start < count {
        let n = block.min(count - start);
        let aligned = n.div_ceil(16) * 16;
        let control = if version == 0 { &[][..] } else { r.take(stride / 4, "block control bytes")? };
        let out_block = &mut out[start * stride..(start + n) * stride];
        for k in (0..stride).step_by(4) {
            let ctrl_byte = if version == 0 { 0 } else { control[k / 4] };
            for j in 0..4 {
                let plane = &mut planes[j * aligned..(j + 1) * aligned];
                let ctrl = (ctrl_byte >> (j * 2)) & 3;
                match (version, ctrl) {
                    (0, _) => decode_bytes(&mut r, plane, &[0, 2, 4, 8])?,
                    (_, 0) => decode_bytes(&mut r, plane, &[0, 1, 2, 4])?,
                    (_, 1) => decode_bytes(&mut r, plane, &[1, 2, 4, 8])?,
                    (_, 2) => plane.fill(0),
                    _ => {
                        plane[..n].copy_from_slice(r.take(n, "literal byte deltas")?);
                        plane[n..].fill(0);
                    }
                }
            }
            let channel = if version == 0 { 0 } else { channels[k / 4] };
            let p = |j: usize, i: usize| planes[j * aligned + i];
            match channel & 0x0f {
                0 => {
                    for j in 0..4 {
                        let mut prev = last[k + j];
                        for i in 0..n {
                            prev = unzigzag8(p(j, i)).wrapping_add(prev);
                            out_block[i * stride + k + j] = prev;
                        }
                    }
                }
                1 => {
                    for h in [0, 2] {
                        let mut prev = u16::from_le_bytes([last[k + h], last[k + h + 1]]);
                        for i in 0..n {
                            let d = u16::from_le_bytes([p(h, i), p(h + 1, i)]);
                            prev = unzigzag16(d).wrapping_add(prev);
                            out_block[i * stride + k + h..i * stride + k + h + 2].copy_from_slice(&prev.to_le_bytes());
                        }
                    }
                }
                _ => {
                    let rot = (32 - u32::from(channel >> 4)) & 31;
                    let mut prev = u32::from_le_bytes([last[k], last[k + 1], last[k + 2], last[k + 3]]);
                    for i in 0..n {
                        let d = u32::from_le_bytes([p(0, i), p(1, i), p(2, i), p(3, i)]);
                        prev ^= d.rotate_left(rot);
                        out_block[i * stride + k..i * stride + k + 4].copy_from_slice(&prev.to_le_bytes());
                    }
                }
            }
            last[k..k + 4].copy_from_slice(&out_block[(n - 1) * stride + k..(n - 1) * stride + k + 4]);
        }
        start += n;
    }
    r.finish()?;
    Ok(out)
}

/// Ring buffer of the last 16 pushed values that refuses reads of never-written entries.
struct Fifo<T: Copy> {
    items: [T; 16],
    offset: usize,
    len: usize,
}

impl<T: Copy> Fifo<T> {
    fn new(fill: T) -> Self {
        Self { items: [fill; 16], offset: 0, len: 0 }
    }
    fn push(&mut self, v: T) {
        self.items[self.offset] = v;
        self.offset = (self.offset + 1) & 15;
        self.len = (self.len + 1).min(16);
    }
    /// Entry `back` (0 = most recently pushed).
    fn get(&self, back: usize, what: &str, tri: usize) -> Result<T, MeshoptError> {
        if back >= self.len {
            return Err(MeshoptError::Malformed(format!(
                "triangle {tri} reads {what} FIFO entry {back}, only {} written",
                self.len
            )));
        }
        Ok(self.items[(self.offset + 15 - back) & 15])
    }
}

/// Decodes a `TRIANGLES` stream (`meshopt_decodeIndexBuffer`, versions 0 and 1) of `count`
/// indices (a multiple of 3).
pub fn decode_index_buffer(count: usize, data: &[u8]) -> Result<Vec<u32>, MeshoptError> {
    if count % 3 != 0 {
        return Err(MeshoptError::Parameters(format!("TRIANGLES count {count} is not a multiple of 3")));
    }
    let tris = count / 3;
    let needed = 1 + tris + 16;
    if data.len() < needed {
        return Err(MeshoptError::Truncated {
            what: "triangle codes and tail",
            offset: 0,
            needed,
            available: data.len(),
        });
    }
    let header = data[0];
    if header & 0xf0 != 0xe0 {
        return Err(MeshoptError::BadHeader { codec: "index", found: header, expected: 0xe1 });
    }
    let version = header & 0x0f;
    if version > 1 {
        return Err(MeshoptError::UnsupportedVersion { codec: "index codec", version, max: 1 });
    }
    let codes = &data[1..1 + tris];
    let codeaux = &data[data.len() - 16..];
    let mut r = Reader { data: &data[..data.len() - 16], pos: 1 + tris };
    let mut edges: Fifo<(u32, u32)> = Fifo::new((0, 0));
    let mut verts: Fifo<u32> = Fifo::new(0);
    let mut next = 0u32;
    let mut last = 0u32;
    let decode_index = |r: &mut Reader, last: &mut u32| -> Result<u32, MeshoptError> {
        let v = r.vbyte()?;
        *last = last.wrapping_add(unzigzag32(v));
        Ok(*last)
    };
    // Codes 0xX1..=0xXc (version 1) or 0xXe (version 0) read the vertex FIFO.
    let fifo_max = if version >= 1 { 13 } else { 15 };
    let mut out = Vec::with_capacity(count);
    for (t, &code) in codes.iter().enumerate() {
        let (a, b, c);
        if code < 0xf0 {
            let fe = usize::from(code >> 4);
            (a, b) = edges.get(fe, "edge", t)?;
            let fec = code & 15;
            if fec == 0 {
                c = next;
                next = next.wrapping_add(1);
                verts.push(c);
            } else if fec < fifo_max {
                c = verts.get(usize::from(fec), "vertex", t)?;
            } else if fec != 15 {
                // 0xXd: last - 1, 0xXe: last + 1 (version 1 only).
                c = if fec == 13 { last.wrapping_sub(1) } else { last.wrapping_add(1) };
                last = c;
                verts.push(c);
            } else {
                c = decode_index(&mut r, &mut last)?;
                verts.push(c);
            }
            edges.push((c, b));
            edges.push((a, c));
        } else {
            let aux;
            let explicit_a;
            if code < 0xfe {
                aux = codeaux[usize::from(code & 15)];
                explicit_a = false;
            } else {
                aux = r.byte("explicit triangle code")?;
                if aux == 0 {
                    next = 0;
                }
                explicit_a = code == 0xff;
            }
            let (feb, fec) = (aux >> 4, aux & 15);
            if code < 0xfe && (feb == 15 || fec == 15) {
                return Err(MeshoptError::Malformed(format!("codeaux entry 0x{aux:02x} has a nibble 0xf")));
            }
            if explicit_a {
                a = decode_index(&mut r, &mut last)?;
            } else {
                a = next;
                next = next.wrapping_add(1);
            }
            let mut pick = |fe: u8, r: &mut Reader| -> Result<u32, MeshoptError> {
                Ok(match fe {
                    0 => {
                        let v = next;
                        next = next.wrapping_add(1);
                        v
                    }
                    15 => decode_index(r, &mut last)?,
                    _ => verts.get(usize::from(fe) - 1, "vertex", t)?,
                })
            };
            b = pick(feb, &mut r)?;
            c = pick(fec, &mut r)?;
            verts.push(a);
            if feb == 0 || feb == 15 {
                verts.push(b);
            }
            if fec == 0 || fec == 15 {
                verts.push(c);
            }
            edges.push((b, a));
            edges.push((c, b));
            edges.push((a, c));
        }
        out.extend_from_slice(&[a, b, c]);
    }
    r.finish()?;
    Ok(out)
}

/// Decodes an `INDICES` stream (`meshopt_decodeIndexSequence`) of `count` indices.
pub fn decode_index_sequence(count: usize, data: &[u8]) -> Result<Vec<u32>, MeshoptError> {
    let needed = count.saturating_add(5);
    if data.len() < needed {
        return Err(MeshoptError::Truncated {
            what: "index sequence and tail",
            offset: 0,
            needed,
            available: data.len(),
        });
    }
    let header = data[0];
    if header & 0xf0 != 0xd0 {
        return Err(MeshoptError::BadHeader { codec: "index sequence", found: header, expected: 0xd1 });
    }
    let version = header & 0x0f;
    if version > 1 {
        return Err(MeshoptError::UnsupportedVersion { codec: "index sequence codec", version, max: 1 });
    }
    let mut r = Reader { data: &data[..data.len() - 4], pos: 1 };
    let mut last = [0u32; 2];
    let mut out = Vec::with_capacity(count);
    for _ in 0..count {
        let v = r.vbyte()?;
        let base = (v & 1) as usize;
        let idx = last[base].wrapping_add(unzigzag32(v >> 1));
        last[base] = idx;
        out.push(idx);
    }
    r.finish()?;
    Ok(out)
}

/// Rounds half away from zero and converts (saturating; NaN → 0).
fn round_i32(x: f32) -> i32 {
    x.round() as i32
}

/// Applies a post-decode `filter` in place to `data` (elements of `stride` bytes).
pub fn apply_filter(filter: Filter, stride: usize, data: &mut [u8]) -> Result<(), MeshoptError> {
    let bad =
        |what: &str| Err(MeshoptError::Parameters(format!("filter {filter:?} needs {what}, byteStride is {stride}")));
    match filter {
        Filter::None => {}
        Filter::Octahedral => match stride {
            4 => {
                for e in data.chunks_exact_mut(4) {
                    let v = octahedral([e[0] as i8, e[1] as i8, e[2] as i8].map(f32::from), 127.0);
                    for (o, x) in e.iter_mut().zip(v) {
                        *o = x.clamp(-127, 127) as i8 as u8;
                    }
                }
            }
            8 => {
                for e in data.chunks_exact_mut(8) {
                    let c = |i: usize| f32::from(i16::from_le_bytes([e[2 * i], e[2 * i + 1]]));
                    let v = octahedral([c(0), c(1), c(2)], 32767.0);
                    for (i, x) in v.iter().enumerate() {
                        e[2 * i..2 * i + 2].copy_from_slice(&((*x).clamp(-32767, 32767) as i16).to_le_bytes());
                    }
                }
            }
            _ => return bad("byteStride 4 or 8"),
        },
        Filter::Quaternion => {
            if stride != 8 {
                return bad("byteStride 8");
            }
            for e in data.chunks_exact_mut(8) {
                let c = |i: usize| i16::from_le_bytes([e[2 * i], e[2 * i + 1]]);
                let one = f32::from(c(3) | 3);
                let s = std::f32::consts::FRAC_1_SQRT_2 / one;
                let (x, y, z) = (f32::from(c(0)) * s, f32::from(c(1)) * s, f32::from(c(2)) * s);
                let w = (1.0 - x * x - y * y - z * z).max(0.0).sqrt();
                let max = (c(3) & 3) as usize;
                let mut q = [0i16; 4];
                for (k, v) in [(1, x), (2, y), (3, z), (0, w)] {
                    q[(max + k) % 4] = round_i32(v * 32767.0).clamp(-32767, 32767) as i16;
                }
                for (i, v) in q.iter().enumerate() {
                    e[2 * i..2 * i + 2].copy_from_slice(&v.to_le_bytes());
                }
            }
        }
        Filter::Exponential => {
            if stride % 4 != 0 {
                return bad("a byteStride divisible by 4");
            }
            for e in data.chunks_exact_mut(4) {
                let v = i32::from_le_bytes([e[0], e[1], e[2], e[3]]);
                let exp = v >> 24;
                let m = (v << 8) >> 8;
                let f = (f64::from(m) * 2f64.powi(exp)) as f32;
                e.copy_from_slice(&f.to_le_bytes());
            }
        }
        Filter::Color => match stride {
            4 => {
                for e in data.chunks_exact_mut(4) {
                    let rgba =
                        ycocg([i32::from(e[0]), i32::from(e[1] as i8), i32::from(e[2] as i8), i32::from(e[3])], 255.0);
                    for (o, x) in e.iter_mut().zip(rgba) {
                        *o = x as u8;
                    }
                }
            }
            8 => {
                for e in data.chunks_exact_mut(8) {
                    let u = |i: usize| u16::from_le_bytes([e[2 * i], e[2 * i + 1]]);
                    let rgba = ycocg(
                        [i32::from(u(0)), i32::from(u(1) as i16), i32::from(u(2) as i16), i32::from(u(3))],
                        65535.0,
                    );
                    for (i, x) in rgba.iter().enumerate() {
                        e[2 * i..2 * i + 2].copy_from_slice(&(*x as u16).to_le_bytes());
                    }
                }
            }
            _ => return bad("byteStride 4 or 8"),
        },
    }
    Ok(())
}

/// Octahedral decode of (x, y, one) to a unit vector scaled by `max` and rounded; the fourth
/// component is left untouched by the caller.
fn octahedral([x, y, one]: [f32; 3], max: f32) -> [i32; 3] {
    if one == 0.0 {
        return [0, 0, 0];
    }
    let (mut x, mut y) = (x / one, y / one);
    let z = 1.0 - x.abs() - y.abs();
    let t = z.min(0.0);
    x -= t.copysign(x);
    y -= t.copysign(y);
    let len = (x * x + y * y + z * z).sqrt();
    if len == 0.0 || !len.is_finite() {
        return [0, 0, 0];
    }
    [round_i32(x / len * max), round_i32(y / len * max), round_i32(z / len * max)]
}

/// YCoCg (with K-bit scale recovered from the alpha high bit) to RGBA scaled to `max`, clamped
/// to [0, max].
fn ycocg([y, co, cg, a]: [i32; 4], max: f32) -> [i32; 4] {
    if a == 0 {
        return [0; 4];
    }
    let scale = (1i32 << (32 - a.leading_zeros())) - 1; // (1 << (msb + 1)) - 1
    let (r, g, b) = (y + co - cg, y + cg, y - co - cg);
    let a = a & (scale >> 1);
    let a = (a << 1) | (a & 1);
    let s = max / scale as f32;
    let m = max as i32;
    [r, g, b, a].map(|v| round_i32(v as f32 * s).clamp(0, m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    // ---- A small encoder written from the specification's bitstream description (Appendix A),
    // used to round-trip data through the decoder. It picks the smallest group encoding, so the
    // sentinel paths of every bit width are exercised.

    fn zigzag8(v: u8) -> u8 {
        ((v as i8 >> 7) as u8) ^ (v << 1)
    }
    fn zigzag16(v: u16) -> u16 {
        ((v as i16 >> 15) as u16) ^ (v << 1)
    }

    fn encode_group(out: &mut Vec<u8>, d: &[u8], bits: u32) {
        match bits {
            0 => {}
            8 => out.extend_from_slice(d),
            _ => {
                let sentinel = (1u8 << bits) - 1;
                let per_byte = 8 / bits as usize;
                for chunk in d.chunks(per_byte) {
                    let mut byte = 0u8;
                    for (s, &v) in chunk.iter().enumerate() {
                        let enc = v.min(sentinel);
                        byte |= if bits == 1 { enc << s } else { enc << (8 - bits as usize * (s + 1)) };
                    }
                    out.push(byte);
                }
                out.extend(d.iter().copied().filter(|&v| v >= sentinel));
            }
        }
    }

    fn group_size(d: &[u8], bits: u32) -> Option<usize> {
        match bits {
            0 => d.iter().all(|&v| v == 0).then_some(0),
            8 => Some(16),
            _ => Some(16 * bits as usize / 8 + d.iter().filter(|&&v| v >= (1 << bits) - 1).count()),
        }
    }

    fn encode_bytes(d: &[u8], table: &[u32; 4]) -> Option<Vec<u8>> {
        let groups = d.len() / 16;
        let mut header = vec![0u8; groups.div_ceil(4)];
        let mut body = Vec::new();
        for g in 0..groups {
            let gd = &d[g * 16..g * 16 + 16];
            let (k, _) = (0..4).filter_map(|k| group_size(gd, table[k]).map(|s| (k, s))).min_by_key(|&(_, s)| s)?;
            header[g / 4] |= (k as u8) << ((g % 4) * 2);
            encode_group(&mut body, gd, table[k]);
        }
        header.extend(body);
        Some(header)
    }

    /// Encodes `data` (count × stride bytes). `channels` (version 1 only): per 4-byte channel,
    /// mode 0 (bytes), 1 (16-bit) or 2 | rot << 4 (32-bit XOR).
    #[allow(clippy::needless_range_loop)] // indices address several planes and elements at once
    fn encode_vertex(data: &[u8], stride: usize, version: u8, channels: &[u8]) -> Vec<u8> {
        let count = data.len() / stride;
        let mut out = vec![0xa0 | version];
        let base: Vec<u8> = if count > 0 { data[..stride].to_vec() } else { vec![0; stride] };
        let mut last = base.clone();
        let block = vertex_block_elements(stride);
        let mut start = 0;
        while start < count {
            let n = block.min(count - start);
            let aligned = n.div_ceil(16) * 16;
            let el = |i: usize, b: usize| data[(start + i) * stride + b];
            let mut planes = vec![vec![0u8; aligned]; stride];
            for k in (0..stride).step_by(4) {
                let ch = if version == 0 { 0 } else { channels[k / 4] };
                for i in 0..n {
                    let prev = |b: usize| if i == 0 { last[b] } else { el(i - 1, b) };
                    match ch & 3 {
                        0 => {
                            for j in 0..4 {
                                planes[k + j][i] = zigzag8(el(i, k + j).wrapping_sub(prev(k + j)));
                            }
                        }
                        1 => {
                            for h in [0, 2] {
                                let v = u16::from_le_bytes([el(i, k + h), el(i, k + h + 1)]);
                                let p = u16::from_le_bytes([prev(k + h), prev(k + h + 1)]);
                                let d = zigzag16(v.wrapping_sub(p)).to_le_bytes();
                                planes[k + h][i] = d[0];
                                planes[k + h + 1][i] = d[1];
                            }
                        }
                        _ => {
                            let v = u32::from_le_bytes([el(i, k), el(i, k + 1), el(i, k + 2), el(i, k + 3)]);
                            let p = u32::from_le_bytes([prev(k), prev(k + 1), prev(k + 2), prev(k + 3)]);
                            let d = (v ^ p).rotate_left(u32::from(ch >> 4)).to_le_bytes();
                            for j in 0..4 {
                                planes[k + j][i] = d[j];
                            }
                        }
                    }
                }
            }
            if version == 0 {
                for p in &planes {
                    out.extend(encode_bytes(p, &[0, 2, 4, 8]).unwrap());
                }
            } else {
                let mut control = vec![0u8; stride / 4];
                let mut body = Vec::new();
                for (b, p) in planes.iter().enumerate() {
                    let mut options: Vec<(u8, Vec<u8>)> = Vec::new();
                    if let Some(e) = encode_bytes(p, &[0, 1, 2, 4]) {
                        options.push((0, e));
                    }
                    options.push((1, encode_bytes(p, &[1, 2, 4, 8]).unwrap()));
                    if p.iter().all(|&v| v == 0) {
                        options.push((2, Vec::new()));
                    }
                    options.push((3, p[..n].to_vec()));
                    let (ctrl, e) = options.into_iter().min_by_key(|(_, e)| e.len()).unwrap();
                    control[b / 4] |= ctrl << ((b % 4) * 2);
                    body.extend(e);
                }
                out.extend(control);
                out.extend(body);
            }
            last.copy_from_slice(&data[(start + n - 1) * stride..(start + n) * stride]);
            start += n;
        }
        let tail = stride + if version == 0 { 0 } else { stride / 4 };
        let min: usize = if version == 0 { 32 } else { 24 };
        out.extend(std::iter::repeat_n(0, min.saturating_sub(tail)));
        out.extend(&base);
        if version == 1 {
            out.extend(&channels[..stride / 4]);
        }
        out
    }

    #[test]
    fn spec_example_of_4bit_sentinel_group() {
        // KHR_meshopt_compression Appendix A, "Channel mode 0": these 10 bytes encode 16 deltas.
        let bytes = [0x17, 0x5f, 0xf0, 0xbc, 0x77, 0xa9, 0x21, 0x00, 0x34, 0xb5];
        let mut r = Reader { data: &bytes, pos: 0 };
        let mut out = [0u8; 16];
        decode_group(&mut r, &mut out, 4).unwrap();
        assert_eq!(r.pos, bytes.len());
        let deltas: Vec<i8> = out.iter().map(|&v| unzigzag8(v) as i8).collect();
        assert_eq!(deltas, [-1, -4, -3, 26, -91, 0, -6, 6, -4, -4, 5, -5, 1, -1, 0, 0]);
    }

    #[test]
    fn spec_examples_of_varint_and_zigzag() {
        // The first two are the specification's examples. Its third (`0xff 0xa0 0x05 => 0x1fd005`)
        // reads the groups most significant first, contradicting the LEB128 rule it states and
        // meshoptimizer's `decodeVByte`; LEB128 gives 0x7f + (0x20 << 7) + (0x05 << 14).
        for (bytes, v) in [(&[0x7f][..], 0x7f), (&[0x81, 0x04][..], 0x201), (&[0xff, 0xa0, 0x05][..], 0x1507f)] {
            let mut r = Reader { data: bytes, pos: 0 };
            assert_eq!(r.vbyte().unwrap(), v);
            assert_eq!(r.pos, bytes.len());
        }
        // Spec: encode(v) = v & 0x80 ? ~(v << 1) : v << 1; decode inverts it.
        for v in 0..=255u8 {
            let enc = if v & 0x80 != 0 { !(v << 1) } else { v << 1 };
            assert_eq!(unzigzag8(enc), v);
        }
        assert_eq!(unzigzag16(3), 0xfffe); // -2
        assert_eq!(unzigzag32(4), 2);
    }

    #[test]
    fn one_bit_groups_are_lsb_first() {
        // Deltas 1 at positions 0 and 9, sentinel (1) at position 3 carrying 0x42.
        let mut d = [0u8; 16];
        d[0] = 1;
        d[9] = 1;
        d[3] = 0x42;
        // 1-bit: a delta equal to the sentinel (1) must be stored as an explicit byte.
        let bytes = [0b0000_1001, 0b0000_0010, 0x01, 0x42, 0x01];
        let mut r = Reader { data: &bytes, pos: 0 };
        let mut out = [0u8; 16];
        decode_group(&mut r, &mut out, 1).unwrap();
        assert_eq!(out, d);
        assert_eq!(r.pos, bytes.len());
    }

    #[test]
    fn vertex_round_trip_v0_v1_channel_modes_and_blocks() {
        // 600 elements of 12 bytes: 3 blocks (256, 256, 88), smooth + noisy + constant columns.
        let stride = 12;
        let count = 600;
        let mut data = Vec::with_capacity(count * stride);
        let mut seed = 12345u32;
        for i in 0..count {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let smooth = (i as u32 * 37) as u16;
            data.extend(smooth.to_le_bytes());
            data.extend(((seed >> 16) as u16).to_le_bytes());
            data.extend(((i as f32) * 0.25).to_le_bytes());
            data.extend([7, 7, (i % 3) as u8, (seed >> 24) as u8]);
        }
        let v0 = encode_vertex(&data, stride, 0, &[]);
        assert_eq!(decode_vertex_buffer(count, stride, &v0).unwrap(), data);
        for channels in [[0u8, 0, 0], [1, 1, 0], [2 | (3 << 4), 2, 1], [1, 2 | (15 << 4), 2]] {
            let v1 = encode_vertex(&data, stride, 1, &channels);
            assert_eq!(decode_vertex_buffer(count, stride, &v1).unwrap(), data, "channels {channels:?}");
        }
        // Zero elements: header, padding and tail only.
        let empty = encode_vertex(&[], 8, 0, &[]);
        assert_eq!(empty.len(), 1 + 32);
        assert_eq!(decode_vertex_buffer(0, 8, &empty).unwrap(), Vec::<u8>::new());
    }

    #[test]
    fn vertex_stream_structure_errors() {
        let data: Vec<u8> = (0..64u8).collect();
        let enc = encode_vertex(&data, 16, 0, &[]);
        assert!(matches!(
            decode_vertex_buffer(4, 16, &enc[..enc.len() - 1]),
            Err(MeshoptError::TrailingData { .. } | MeshoptError::Truncated { .. })
        ));
        let mut longer = enc.clone();
        longer.insert(1, 0);
        assert!(decode_vertex_buffer(4, 16, &longer).is_err());
        let mut bad = enc.clone();
        bad[0] = 0xa2;
        assert!(matches!(decode_vertex_buffer(4, 16, &bad), Err(MeshoptError::UnsupportedVersion { version: 2, .. })));
        bad[0] = 0x50;
        assert!(matches!(decode_vertex_buffer(4, 16, &bad), Err(MeshoptError::BadHeader { .. })));
        assert!(matches!(decode_vertex_buffer(4, 6, &enc), Err(MeshoptError::Parameters(_))));
        // A claim of more elements than the stream could hold is refused before allocating.
        assert!(matches!(decode_vertex_buffer(usize::MAX / 32, 16, &enc), Err(MeshoptError::Parameters(_))));
        // Version 1 with an invalid channel mode byte (3).
        let v1 = encode_vertex(&data, 16, 1, &[0, 0, 0, 0]);
        let mut bad = v1.clone();
        let n = bad.len();
        bad[n - 1] = 3;
        assert!(matches!(decode_vertex_buffer(4, 16, &bad), Err(MeshoptError::Malformed(_))));
    }

    /// The stream built by hand in the comments, following Appendix A "Mode 1: triangles".
    fn hand_triangles(version: u8) -> Vec<u8> {
        let mut s = vec![0xe0 | version];
        // codes: 0xf0 (codeaux[0] = 0x00: next, next, next) → (0,1,2)
        //        0x10 (edge 1 = (2,1), c = next)           → (2,1,3)
        //        0x13 (edge 1 = (3,1), vertex FIFO 3 = 0)   → (3,1,0)
        //        0x0f (edge 0 = (3,0), explicit +7)         → (3,0,7)
        //        0x0d (edge 0 = (3,7), last - 1)            → (3,7,6)   [version 1]
        //        0xff (aux 0x1f: a explicit +4, b = FIFO 0, c explicit +290) → (10,6,300)
        s.extend([0xf0, 0x10, 0x13, 0x0f, 0x0d, 0xff]);
        s.extend([0x0e, 0x1f, 0x08, 0xc4, 0x04]);
        s.extend([0u8; 16]);
        s
    }

    #[test]
    fn triangle_codes_decode_as_specified() {
        let tris = decode_index_buffer(18, &hand_triangles(1)).unwrap();
        assert_eq!(tris, [0, 1, 2, 2, 1, 3, 3, 1, 0, 3, 0, 7, 3, 7, 6, 10, 6, 300]);
        // Version 0 has no 0xXd code: 0x0d reads vertex FIFO entry 13, never written here.
        assert!(matches!(decode_index_buffer(18, &hand_triangles(0)), Err(MeshoptError::Malformed(_))));
        // 0xfe with aux 0x00 restarts `next`: (0, 1, 2) twice.
        let mut s = vec![0xe1, 0xf0, 0xfe, 0x00];
        s.extend([0u8; 16]);
        assert_eq!(decode_index_buffer(6, &s).unwrap(), [0, 1, 2, 0, 1, 2]);
        // Structure errors.
        let good = hand_triangles(1);
        assert!(decode_index_buffer(18, &good[..good.len() - 1]).is_err());
        assert!(matches!(decode_index_buffer(18, &good[..20]), Err(MeshoptError::Truncated { .. })));
        let mut extra = good.clone();
        extra.insert(12, 0);
        assert!(matches!(decode_index_buffer(18, &extra), Err(MeshoptError::TrailingData { .. })));
        assert!(matches!(decode_index_buffer(17, &good), Err(MeshoptError::Parameters(_))));
        // An edge FIFO read before any edge exists.
        let mut s = vec![0xe1, 0x00];
        s.extend([0u8; 16]);
        assert!(matches!(decode_index_buffer(3, &s), Err(MeshoptError::Malformed(_))));
    }

    #[test]
    fn index_sequence_uses_two_baselines() {
        // 5 (base 0, +5), 6 (base 0, +1), 100 (base 1, +100), 7 (base 0, +1), 101 (base 1, +1),
        // 99 (base 1, −2): v = zigzag(delta) << 1 | base, LEB128.
        let s = [0xd1, 0x14, 0x04, 0x91, 0x03, 0x04, 0x05, 0x07, 0, 0, 0, 0];
        assert_eq!(decode_index_sequence(6, &s).unwrap(), [5, 6, 100, 7, 101, 99]);
        assert!(matches!(decode_index_sequence(7, &s), Err(MeshoptError::Truncated { .. })));
        assert!(matches!(decode_index_sequence(5, &s), Err(MeshoptError::TrailingData { .. })));
    }

    fn i16s(v: &[u8]) -> Vec<i16> {
        v.chunks_exact(2).map(|c| i16::from_le_bytes([c[0], c[1]])).collect()
    }
    fn bytes16(v: &[i16]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn octahedral_filter_poles_and_unit_length() {
        // 8-bit, K = 8 (one = 127): +Z, +X, −Y, and the (1, 1) corner that folds to −Z; w passes through.
        let mut d: Vec<u8> = [[0i8, 0, 127, 5], [127, 0, 127, -3], [0, -127, 127, 0], [127, 127, 127, 9]]
            .iter()
            .flatten()
            .map(|&x| x as u8)
            .collect();
        apply_filter(Filter::Octahedral, 4, &mut d).unwrap();
        let out: Vec<i8> = d.iter().map(|&x| x as i8).collect();
        assert_eq!(out, [0, 0, 127, 5, 127, 0, 0, -3, 0, -127, 0, 0, 0, 0, -127, 9]);
        // 16-bit, K = 10 (one = 511): every output has unit length within one unit per component
        // and points where the octahedral map says (x : y : z in the same ratios).
        for (x, y) in [(100i16, -200i16), (-300, 150), (400, 400), (-511, 0), (17, -480)] {
            let mut d = bytes16(&[x, y, 511, 1234]);
            apply_filter(Filter::Octahedral, 8, &mut d).unwrap();
            let o = i16s(&d);
            assert_eq!(o[3], 1234);
            let v = [o[0], o[1], o[2]].map(|c| f64::from(c) / 32767.0);
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!((len - 1.0).abs() < 2.0 / 32767.0, "{x} {y}: {v:?}");
            let (fx, fy) = (f64::from(x) / 511.0, f64::from(y) / 511.0);
            let z = 1.0 - fx.abs() - fy.abs();
            let (ex, ey) =
                if z < 0.0 { (fx.signum() * (fx.abs() + z), fy.signum() * (fy.abs() + z)) } else { (fx, fy) };
            let el = (ex * ex + ey * ey + z * z).sqrt();
            for (got, want) in v.iter().zip([ex / el, ey / el, z / el]) {
                assert!((got - want).abs() <= 1.0 / 32767.0, "{x} {y}: {v:?}");
            }
        }
        assert!(apply_filter(Filter::Octahedral, 12, &mut [0; 12]).is_err());
    }

    #[test]
    fn quaternion_filter_identity_and_quarter_turn() {
        // K = 12: one = 2047 with the low two bits replaced by the index of the dropped component.
        let one = 2047i16 & !3;
        let mut d = bytes16(&[0, 0, 0, one | 3]);
        apply_filter(Filter::Quaternion, 8, &mut d).unwrap();
        assert_eq!(i16s(&d), [0, 0, 0, 32767]);
        // 90° about Z: (0, 0, √½, √½); w dropped (index 3), z stored as √½·√2 = 1.0 = 2047.
        let mut d = bytes16(&[0, 0, 2047, one | 3]);
        apply_filter(Filter::Quaternion, 8, &mut d).unwrap();
        let h = (std::f64::consts::FRAC_1_SQRT_2 * 32767.0).round() as i16;
        assert_eq!(i16s(&d), [0, 0, h, h]);
        // The dropped component is x (index 0): stored order is y, z, w.
        let mut d = bytes16(&[0, 0, 0, one]);
        apply_filter(Filter::Quaternion, 8, &mut d).unwrap();
        assert_eq!(i16s(&d), [32767, 0, 0, 0]);
        assert!(apply_filter(Filter::Quaternion, 4, &mut [0; 4]).is_err());
    }

    #[test]
    fn exponential_filter_values() {
        let enc = |e: i32, m: i32| ((e << 24) | (m & 0x00ff_ffff)).to_le_bytes();
        let mut d: Vec<u8> = [enc(-3, 12), enc(0, -1), enc(10, 8_388_607), enc(-100, 1)].concat();
        apply_filter(Filter::Exponential, 16, &mut d).unwrap();
        let f: Vec<f32> = d.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        assert_eq!(f, [1.5, -1.0, 8_388_607.0 * 1024.0, (2f64.powi(-100)) as f32]);
    }

    #[test]
    fn color_filter_ycocg() {
        // K = 8: RGB (200, 100, 40) → Y = (r + 2g + b)/4 = 110, Co = (r − b)/2 = 80,
        // Cg = (2g − r − b)/4 = −10; alpha 7 bits (127) with bit 7 set.
        let mut d = vec![110u8, 80, (-10i8) as u8, 0xff];
        apply_filter(Filter::Color, 4, &mut d).unwrap();
        assert_eq!(d, [200, 100, 40, 255]);
        // K = 6: RGB (60, 30, 12) in 6 bits → Y 33, Co 24, Cg −3; alpha 31 | 0b100000;
        // output scaled by 255 / 63.
        let mut d = vec![33u8, 24, (-3i8) as u8, 0b11_1111];
        apply_filter(Filter::Color, 4, &mut d).unwrap();
        let s: f64 = 255.0 / 63.0;
        assert_eq!(d, [(60.0 * s).round() as u8, (30.0 * s).round() as u8, (12.0 * s).round() as u8, 255]);
        // 16-bit, K = 16: grey 40000 with alpha 0x7fff | 0x8000.
        let mut d: Vec<u8> = [40000u16, 0, 0, 0xffff].iter().flat_map(|x| x.to_le_bytes()).collect();
        apply_filter(Filter::Color, 8, &mut d).unwrap();
        let o: Vec<u16> = d.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
        assert_eq!(o, [40000, 40000, 40000, 65535]);
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

        #[test]
        fn decoders_never_panic_on_random_bytes(
            bytes in proptest::collection::vec(any::<u8>(), 0..400),
            count in 0usize..700,
            stride_k in 1usize..20,
            head in prop_oneof![Just(0xa0u8), Just(0xa1), Just(0xe0), Just(0xe1), Just(0xd1), any::<u8>()],
        ) {
            let mut b = bytes;
            if let Some(f) = b.first_mut() { *f = head; }
            let stride = stride_k * 4;
            if let Ok(v) = decode_vertex_buffer(count, stride, &b) {
                prop_assert_eq!(v.len(), count * stride);
                let mut v = v;
                for f in [Filter::Octahedral, Filter::Quaternion, Filter::Exponential, Filter::Color] {
                    let _ = apply_filter(f, stride, &mut v);
                }
            }
            if let Ok(ix) = decode_index_buffer(count / 3 * 3, &b) {
                prop_assert_eq!(ix.len(), count / 3 * 3);
            }
            if let Ok(ix) = decode_index_sequence(count, &b) {
                prop_assert_eq!(ix.len(), count);
            }
        }

        #[test]
        fn random_attribute_data_round_trips(
            seed in any::<u64>(),
            count in 0usize..300,
            stride_k in 1usize..6,
            version in 0u8..2,
            smooth in any::<bool>(),
        ) {
            let stride = stride_k * 4;
            let mut s = seed | 1;
            let mut data = Vec::with_capacity(count * stride);
            for i in 0..count * stride {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                data.push(if smooth { (i / stride) as u8 ^ ((s as u8) & 3) } else { s as u8 });
            }
            let channels: Vec<u8> = (0..stride / 4).map(|c| [0u8, 1, 2, 2 | (5 << 4)][(seed as usize >> (2 * c)) & 3]).collect();
            let enc = encode_vertex(&data, stride, version, &channels);
            prop_assert_eq!(decode_vertex_buffer(count, stride, &enc).unwrap(), data);
        }
    }
}
