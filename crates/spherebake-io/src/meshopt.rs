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
