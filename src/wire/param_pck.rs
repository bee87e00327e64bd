//! ArduPilot's packed parameter file, `@PARAM/param.pck`, as served over MAVFTP.
//!
//! Format (ArduPilot `libraries/AP_Filesystem/README.md` and `AP_Filesystem_Param.cpp`):
//! a 6-byte little-endian header `magic u16` (0x671B, or 0x671C when entries may carry their
//! default value), `num_params u16`, `total_params u16`; then one entry per parameter:
//! `type:4 | flags:4` (AP_Param type 1=INT8, 2=INT16, 3=INT32, 4=FLOAT; flag bit 0 = a default
//! value follows the value), `common_len:4 | (name_len-1):4`, the name bytes not shared with the
//! previous name, the value little-endian, then the default if flagged. Zero bytes before an
//! entry are padding: the vehicle inserts them so that no multi-byte value straddles a boundary of
//! the FTP read size, which lets a GCS re-fetch one lost block without splicing a value in two.
//!
//! The GCS side reuses [`decode`]; the simulator uses [`encode`].

/// Magic of a file without default values.
pub const MAGIC: u16 = 0x671B;
/// Magic of a file whose entries may carry default values.
pub const MAGIC_WITH_DEFAULTS: u16 = 0x671C;
/// Largest parameter name ArduPilot has (and the PARAM_VALUE field length).
pub const MAX_NAME_LEN: usize = 16;

/// AP_Param storage type of a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PckType {
    Int8 = 1,
    Int16 = 2,
    Int32 = 3,
    Float = 4,
}

impl PckType {
    pub fn from_code(code: u8) -> Option<PckType> {
        match code {
            1 => Some(PckType::Int8),
            2 => Some(PckType::Int16),
            3 => Some(PckType::Int32),
            4 => Some(PckType::Float),
            _ => None,
        }
    }

    /// Bytes the value takes in the file.
    pub fn size(self) -> usize {
        match self {
            PckType::Int8 => 1,
            PckType::Int16 => 2,
            PckType::Int32 | PckType::Float => 4,
        }
    }

    fn write(self, v: f64, out: &mut Vec<u8>) {
        match self {
            PckType::Int8 => out.push(v as i8 as u8),
            PckType::Int16 => out.extend_from_slice(&(v as i16).to_le_bytes()),
            PckType::Int32 => out.extend_from_slice(&(v as i32).to_le_bytes()),
            PckType::Float => out.extend_from_slice(&(v as f32).to_le_bytes()),
        }
    }

    fn read(self, b: &[u8]) -> f64 {
        match self {
            PckType::Int8 => b[0] as i8 as f64,
            PckType::Int16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            PckType::Int32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            PckType::Float => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        }
    }
}

/// One parameter as the packed file carries it. Integer values are exact in `f64`; float values
/// are the `f32` widened.
#[derive(Debug, Clone, PartialEq)]
pub struct PckParam {
    pub name: String,
    pub ptype: PckType,
    pub value: f64,
    /// Present only in files with [`MAGIC_WITH_DEFAULTS`], for parameters not at their default.
    pub default: Option<f64>,
}

/// A decoded file.
#[derive(Debug, Clone, PartialEq)]
pub struct PckFile {
    pub magic: u16,
    /// Parameters in the file (a `?start=&count=` request may send fewer than the total).
    pub num_params: u16,
    /// Parameters the vehicle has.
    pub total_params: u16,
    pub params: Vec<PckParam>,
}

/// Why a packed file did not decode; each names the byte offset where it went wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PckError {
    #[error("param.pck: shorter than its 6-byte header")]
    ShortHeader,
    #[error("param.pck: bad magic {0:#06x} (expected 0x671b or 0x671c)")]
    BadMagic(u16),
    #[error("param.pck: unknown type {code} at offset {offset}")]
    BadType { code: u8, offset: usize },
    #[error("param.pck: entry at offset {offset} runs past the end of the file")]
    Truncated { offset: usize },
    #[error("param.pck: entry at offset {offset} shares {common} name bytes but the previous name has {prev}")]
    BadCommonLen {
        offset: usize,
        common: usize,
        prev: usize,
    },
    #[error(
        "param.pck: name at offset {offset} is not a parameter name (1-16 printable ASCII without spaces, '#' or ',')"
    )]
    BadName { offset: usize },
    #[error("param.pck: header says {expected} parameters, file holds {found}")]
    CountMismatch { expected: u16, found: usize },
}

/// Decode a whole file. Trailing zero padding is accepted; the parameter count must match the
/// header (a short count means the download lost blocks).
pub fn decode(bytes: &[u8]) -> Result<PckFile, PckError> {
    if bytes.len() < 6 {
        return Err(PckError::ShortHeader);
    }
    let magic = u16::from_le_bytes([bytes[0], bytes[1]]);
    if magic != MAGIC && magic != MAGIC_WITH_DEFAULTS {
        return Err(PckError::BadMagic(magic));
    }
    let num_params = u16::from_le_bytes([bytes[2], bytes[3]]);
    let total_params = u16::from_le_bytes([bytes[4], bytes[5]]);
    let mut params = Vec::with_capacity(num_params as usize);
    let mut last = String::new();
    let mut pos = 6;
    while pos < bytes.len() && params.len() < num_params as usize {
        if bytes[pos] == 0 {
            pos += 1; // padding
            continue;
        }
        let offset = pos;
        let code = bytes[pos];
        let ptype = PckType::from_code(code & 0x0F).ok_or(PckError::BadType { code, offset })?;
        let has_default = code & 0x10 != 0;
        let lens = *bytes.get(pos + 1).ok_or(PckError::Truncated { offset })?;
        let common = (lens & 0x0F) as usize;
        let name_len = (lens >> 4) as usize + 1;
        if common > last.len() {
            return Err(PckError::BadCommonLen {
                offset,
                common,
                prev: last.len(),
            });
        }
        let vsize = ptype.size();
        let end = pos + 2 + name_len + vsize * if has_default { 2 } else { 1 };
        if end > bytes.len() {
            return Err(PckError::Truncated { offset });
        }
        let suffix = &bytes[pos + 2..pos + 2 + name_len];
        if !suffix.iter().all(|&b| name_byte_ok(b)) {
            return Err(PckError::BadName { offset });
        }
        let mut name = last[..common].to_string();
        name.push_str(std::str::from_utf8(suffix).map_err(|_| PckError::BadName { offset })?);
        // The shared prefix plus the entry's own bytes can reach 15 + 16 = 31 bytes: held to the
        // same rule as a PARAM_VALUE's name (`name_ok`, 1 to MAX_NAME_LEN bytes).
        if !name_ok(name.as_bytes()) {
            return Err(PckError::BadName { offset });
        }
        let vpos = pos + 2 + name_len;
        let value = ptype.read(&bytes[vpos..]);
        let default = has_default.then(|| ptype.read(&bytes[vpos + vsize..]));
        params.push(PckParam {
            name: name.clone(),
            ptype,
            value,
            default,
        });
        last = name;
        pos = end;
    }
    if params.len() != num_params as usize {
        return Err(PckError::CountMismatch {
            expected: num_params,
            found: params.len(),
        });
    }
    Ok(PckFile {
        magic,
        num_params,
        total_params,
        params,
    })
}

/// A byte a parameter name may hold: printable ASCII but for the space, and for `#` and `,`,
/// which start a comment and separate fields in parameter files.
pub const fn name_byte_ok(b: u8) -> bool {
    b.is_ascii_graphic() && b != b'#' && b != b','
}

/// True for a parameter name: 1 to [`MAX_NAME_LEN`] bytes, each [`name_byte_ok`].
pub fn name_ok(name: &[u8]) -> bool {
    !name.is_empty() && name.len() <= MAX_NAME_LEN && name.iter().all(|&b| name_byte_ok(b))
}

/// Encode parameters the way ArduPilot does for reads of `read_size` bytes (the FTP block size:
/// 239 unless the GCS asked for smaller bursts). Names longer than 16 bytes or empty are
/// skipped, as ArduPilot cannot have them. The magic is [`MAGIC_WITH_DEFAULTS`] when any
/// parameter carries a default, as with ArduPilot's `withdefaults=1`.
pub fn encode(params: &[PckParam], total_params: u16, read_size: usize) -> Vec<u8> {
    let read_size = read_size.max(1);
    let with_defaults = params.iter().any(|p| p.default.is_some());
    let usable: Vec<&PckParam> = params
        .iter()
        .filter(|p| !p.name.is_empty() && p.name.len() <= MAX_NAME_LEN && p.name.is_ascii())
        .collect();
    let mut out = Vec::with_capacity(6 + usable.len() * 12);
    let magic = if with_defaults {
        MAGIC_WITH_DEFAULTS
    } else {
        MAGIC
    };
    out.extend_from_slice(&magic.to_le_bytes());
    out.extend_from_slice(&(usable.len().min(u16::MAX as usize) as u16).to_le_bytes());
    out.extend_from_slice(&total_params.to_le_bytes());
    let mut last: &str = "";
    for p in usable {
        let at = out.len();
        encode_entry(p, last, at, read_size, &mut out);
        last = &p.name;
    }
    out
}

/// Append one entry (`AP_Filesystem_Param::pack_param`) for a parameter that follows `last`,
/// starting at file offset `at` (the 6-byte header counted) of a file read `read_size` bytes at
/// a time: zero padding first if a multi-byte value would otherwise straddle a block boundary.
/// Returns the bytes appended. `p.name` must be 1 to 16 ASCII bytes.
pub fn encode_entry(
    p: &PckParam,
    last: &str,
    at: usize,
    read_size: usize,
    out: &mut Vec<u8>,
) -> usize {
    let read_size = read_size.max(1);
    let before = out.len();
    let name = p.name.as_bytes();
    let mut common = name
        .iter()
        .zip(last.as_bytes())
        .take_while(|(a, b)| a == b)
        .count()
        .min(15);
    if common == name.len() {
        // The name is a prefix of (or equal to) the previous: send at least one byte.
        common -= 1;
    }
    let suffix = &name[common..];
    let vsize = p.ptype.size();
    let packed_len = 2 + suffix.len() + vsize * if p.default.is_some() { 2 } else { 1 };
    // ArduPilot's rule: if the entry would end just past a block boundary by less than one
    // value, pad so the value starts in the next block.
    if vsize > 1 {
        let ofs_mod = (at + packed_len) % read_size;
        if ofs_mod > 0 && ofs_mod < vsize {
            let pad = vsize - ofs_mod;
            out.extend(std::iter::repeat_n(0u8, pad));
        }
    }
    let flags = if p.default.is_some() { 0x10 } else { 0 };
    out.push(p.ptype as u8 | flags);
    out.push(common as u8 | (((suffix.len() - 1) as u8) << 4));
    out.extend_from_slice(suffix);
    p.ptype.write(p.value, out);
    if let Some(d) = p.default {
        p.ptype.write(d, out);
    }
    out.len() - before
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(name: &str, ptype: PckType, value: f64) -> PckParam {
        PckParam {
            name: name.into(),
            ptype,
            value,
            default: None,
        }
    }

    #[test]
    fn round_trip_with_prefixes_and_all_types() {
        let params = vec![
            p("ACRO_BAL_PITCH", PckType::Float, 1.0),
            p("ACRO_BAL_ROLL", PckType::Float, 1.5),
            p("ACRO", PckType::Int8, -3.0),
            p("ACRO", PckType::Int8, 4.0),
            p("SERIAL1_BAUD", PckType::Int32, 57.0),
            p("SYSID_THISMAV", PckType::Int16, 1.0),
            p("COMPASS_DEV_ID", PckType::Int32, 97539.0),
            p("A_VERY_LONG_NAME", PckType::Float, -0.25),
        ];
        for read_size in [239, 110, 16, 7] {
            let bytes = encode(&params, 8, read_size);
            let f = decode(&bytes).unwrap();
            assert_eq!(f.magic, MAGIC);
            assert_eq!((f.num_params, f.total_params), (8, 8));
            assert_eq!(f.params, params, "read size {read_size}");
        }
    }

    #[test]
    fn values_never_straddle_a_block() {
        let params: Vec<PckParam> = (0..200)
            .map(|i| p(&format!("PARAM_{i:03}_X"), PckType::Float, i as f64))
            .collect();
        let read_size = 37;
        let bytes = encode(&params, 200, read_size);
        assert_eq!(decode(&bytes).unwrap().params, params);
        // Walk the entries: every 4-byte value lies inside one block.
        let mut pos = 6;
        let mut n = 0;
        while n < 200 {
            if bytes[pos] == 0 {
                pos += 1;
                continue;
            }
            let name_len = (bytes[pos + 1] >> 4) as usize + 1;
            let v = pos + 2 + name_len;
            assert_eq!(v / read_size, (v + 3) / read_size, "value at {v} straddles");
            pos = v + 4;
            n += 1;
        }
    }

    #[test]
    fn a_name_longer_than_16_bytes_through_the_shared_prefix_is_refused() {
        // Built by hand from ArduPilot's layout (AP_Param::send_parameter): u16 magic, u16
        // count, u16 total; per entry a type byte (4 = FLOAT), a byte holding the shared
        // prefix length (low nibble) and name length - 1 (high nibble), the name bytes, the value.
        let mut f = vec![0x1b, 0x67, 2, 0, 2, 0];
        f.extend([4, 0xF0]);
        f.extend(b"ABCDEFGHIJKLMNOP");
        f.extend(1.0f32.to_le_bytes());
        // 15 shared bytes + 16 own = 31 bytes: no parameter can have this name.
        let second = f.len();
        f.extend([4, 0xFF]);
        f.extend(b"QRSTUVWXYZ012345");
        f.extend(2.0f32.to_le_bytes());
        assert_eq!(decode(&f), Err(PckError::BadName { offset: second }));
        // 15 shared + 1 own = 16 bytes is a parameter name.
        let mut ok = f[..second].to_vec();
        ok.extend([4, 0x0F, b'Q']);
        ok.extend(2.0f32.to_le_bytes());
        let d = decode(&ok).unwrap();
        assert_eq!(d.params[1].name, "ABCDEFGHIJKLMNOQ");
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        assert_eq!(decode(&[]), Err(PckError::ShortHeader));
        assert_eq!(decode(&[1, 2, 3, 4, 5, 6]), Err(PckError::BadMagic(0x0201)));
        let mut b = encode(&[p("X", PckType::Float, 1.0)], 1, 239);
        b.truncate(b.len() - 1);
        assert!(matches!(decode(&b), Err(PckError::Truncated { .. })));
        assert!(matches!(
            decode(&[0x1B, 0x67, 1, 0, 1, 0, 0x09, 0x00]),
            Err(PckError::BadType { .. })
        ));
        assert!(matches!(
            decode(&[0x1B, 0x67, 1, 0, 1, 0, 0x04, 0x03, b'A', 0, 0, 0, 0]),
            Err(PckError::BadCommonLen { .. })
        ));
        assert!(matches!(
            decode(&[0x1B, 0x67, 2, 0, 2, 0]),
            Err(PckError::CountMismatch { .. })
        ));
        // Random bytes after a valid header never panic.
        let mut rng = crate::sim::rng::Rng::new(5);
        for _ in 0..2000 {
            let mut b = vec![0x1B, 0x67, 50, 0, 50, 0];
            for _ in 0..rng.below(200) {
                b.push(rng.next_u64() as u8);
            }
            let _ = decode(&b);
        }
    }
}
