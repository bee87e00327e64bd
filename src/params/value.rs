//! Parameter values on the wire: MAV_PARAM_TYPE, the two ways a value rides in PARAM_VALUE's
//! float, ranges, and how a value is written for people.
//!
//! - **C cast** (ArduPilot only): the float holds the number, `param_value = (float)value`;
//!   whole numbers beyond ±2^24 do not all fit ([`carry_check`] refuses them).
//! - **Bytewise** (the protocol's default: PX4 and every other autopilot): the float's four bytes
//!   hold the value's own bytes (little-endian, low bytes first, the rest zero), so an INT32 of 1
//!   travels as the float whose bits are 1.
//!
//! MAVLink parameter protocol: <https://mavlink.io/en/services/parameter.html>.

/// MAV_PARAM_TYPE, by its wire code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ParamType {
    Uint8 = 1,
    Int8 = 2,
    Uint16 = 3,
    Int16 = 4,
    Uint32 = 5,
    Int32 = 6,
    Uint64 = 7,
    Int64 = 8,
    Real32 = 9,
    Real64 = 10,
}

impl ParamType {
    pub fn from_code(code: u8) -> Option<ParamType> {
        use ParamType::*;
        Some(match code {
            1 => Uint8,
            2 => Int8,
            3 => Uint16,
            4 => Int16,
            5 => Uint32,
            6 => Int32,
            7 => Uint64,
            8 => Int64,
            9 => Real32,
            10 => Real64,
            _ => return None,
        })
    }

    pub fn code(self) -> u8 {
        self as u8
    }

    pub fn is_integer(self) -> bool {
        !matches!(self, ParamType::Real32 | ParamType::Real64)
    }

    /// The name used in QGroundControl's `.params` files and on screen.
    pub fn name(self) -> &'static str {
        use ParamType::*;
        match self {
            Uint8 => "UINT8",
            Int8 => "INT8",
            Uint16 => "UINT16",
            Int16 => "INT16",
            Uint32 => "UINT32",
            Int32 => "INT32",
            Uint64 => "UINT64",
            Int64 => "INT64",
            Real32 => "REAL32",
            Real64 => "REAL64",
        }
    }

    /// Smallest and largest value the type holds (for reals, the finite `f32`/`f64` range).
    pub fn range(self) -> (f64, f64) {
        use ParamType::*;
        match self {
            Uint8 => (0.0, u8::MAX as f64),
            Int8 => (i8::MIN as f64, i8::MAX as f64),
            Uint16 => (0.0, u16::MAX as f64),
            Int16 => (i16::MIN as f64, i16::MAX as f64),
            Uint32 => (0.0, u32::MAX as f64),
            Int32 => (i32::MIN as f64, i32::MAX as f64),
            Uint64 => (0.0, u64::MAX as f64),
            Int64 => (i64::MIN as f64, i64::MAX as f64),
            Real32 => (f32::MIN as f64, f32::MAX as f64),
            Real64 => (f64::MIN, f64::MAX),
        }
    }

    /// Why `v` cannot be a value of this type, if it cannot.
    pub fn check(self, v: f64) -> Result<(), String> {
        if !v.is_finite() {
            return Err(format!("{v} is not a number a {} can hold", self.name()));
        }
        let (lo, hi) = self.range();
        if self.is_integer() && v.fract() != 0.0 {
            return Err(format!("{} holds whole numbers only", self.name()));
        }
        if v < lo || v > hi {
            return Err(format!(
                "{} is out of range for {} ({} to {})",
                fmt_plain(v),
                self.name(),
                fmt_plain(lo),
                fmt_plain(hi)
            ));
        }
        Ok(())
    }
}

/// How integer values ride in PARAM_VALUE / PARAM_SET's float.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// The float holds the number (ArduPilot).
    CCast,
    /// The float's bytes are the integer's bytes (PX4).
    Bytewise,
}

impl Encoding {
    pub fn name(self) -> &'static str {
        match self {
            Encoding::CCast => "C-cast",
            Encoding::Bytewise => "bytewise",
        }
    }

    /// The word `param encoding` takes.
    pub fn cli_name(self) -> &'static str {
        match self {
            Encoding::CCast => "ccast",
            Encoding::Bytewise => "bytewise",
        }
    }

    /// The other one.
    pub fn other(self) -> Encoding {
        match self {
            Encoding::CCast => Encoding::Bytewise,
            Encoding::Bytewise => Encoding::CCast,
        }
    }
}

/// Largest whole number below which every whole number fits a float exactly (2^24).
pub const FLOAT_EXACT: f64 = 16_777_216.0;

/// Why `v` (already a value of type `t`) cannot ride exactly in the float under `enc`: a value
/// the vehicle cannot hold exactly is refused before it is sent.
pub fn carry_check(v: f64, t: ParamType, enc: Encoding) -> Result<(), String> {
    use ParamType::*;
    if !t.is_integer() {
        return Ok(());
    }
    match enc {
        Encoding::CCast if (v as f32) as f64 != v => Err(format!(
            "{} cannot be sent exactly: this vehicle takes integers C-cast in a float, which \
             holds whole numbers exactly only up to ±{} (it would arrive as {})",
            fmt_plain(v),
            fmt_plain(FLOAT_EXACT),
            fmt_plain(v as f32 as f64)
        )),
        Encoding::Bytewise
            if matches!(t, Uint64 | Int64) && !(i32::MIN as f64..=u32::MAX as f64).contains(&v) =>
        {
            Err(format!(
                "{} cannot be sent exactly: a bytewise float carries 32 bits of a {}",
                fmt_plain(v),
                t.name()
            ))
        }
        _ => Ok(()),
    }
}

/// Why the float `f` of a PARAM_VALUE cannot be a value of integer type `t` sent under `enc`
/// (so the encoding looks wrong), if it cannot.
pub fn implausible(f: f32, t: ParamType, enc: Encoding) -> Option<String> {
    use ParamType::*;
    if !t.is_integer() {
        return None;
    }
    match enc {
        Encoding::CCast => {
            if f.is_nan() {
                Some("the float is NaN".into())
            } else if f.is_infinite() {
                Some("the float is infinite".into())
            } else if f.is_subnormal() {
                Some(format!("the float {f:e} is a denormal"))
            } else if f == 0.0 && f.is_sign_negative() {
                Some("the float is -0".into())
            } else if f.fract() != 0.0 {
                Some(format!("the float {f:e} is not a whole number"))
            } else {
                let (lo, hi) = t.range();
                (!(lo..=hi).contains(&(f as f64)))
                    .then(|| format!("{} is out of range for {}", fmt_plain(f as f64), t.name()))
            }
        }
        Encoding::Bytewise => {
            let bits = f.to_bits();
            // The rest zero, or (a signed value's sign) extended.
            let (high, ext) = match t {
                Uint8 => (bits >> 8, None),
                Int8 => (bits >> 8, (bits & 0x80 != 0).then_some(0xFF_FFFF)),
                Uint16 => (bits >> 16, None),
                Int16 => (bits >> 16, (bits & 0x8000 != 0).then_some(0xFFFF)),
                _ => (0, None),
            };
            (high != 0 && Some(high) != ext)
                .then(|| format!("the float's bits {bits:#010x} do not fit a {}", t.name()))
        }
    }
}

/// The value carried by `f` for a parameter of type `t`.
pub fn decode(f: f32, t: ParamType, enc: Encoding) -> f64 {
    use ParamType::*;
    match (enc, t) {
        (_, Real32) | (_, Real64) => f as f64,
        // The float holds a whole number; anything else is rounded as the vehicle would cast.
        (Encoding::CCast, _) if f.is_finite() => (f as f64).round(),
        (Encoding::CCast, _) => 0.0,
        (Encoding::Bytewise, _) => {
            let b = f.to_le_bytes();
            match t {
                Uint8 => b[0] as f64,
                Int8 => b[0] as i8 as f64,
                Uint16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                Int16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                Uint32 | Uint64 => u32::from_le_bytes(b) as f64,
                Int32 | Int64 => i32::from_le_bytes(b) as f64,
                Real32 | Real64 => unreachable!(),
            }
        }
    }
}

/// The float that carries `v` (already checked against the type) for type `t`.
pub fn encode(v: f64, t: ParamType, enc: Encoding) -> f32 {
    use ParamType::*;
    match (enc, t) {
        (_, Real32) | (_, Real64) | (Encoding::CCast, _) => v as f32,
        (Encoding::Bytewise, _) => {
            let mut b = [0u8; 4];
            match t {
                Uint8 => b[0] = v as u8,
                Int8 => b[0] = v as i8 as u8,
                Uint16 => b[..2].copy_from_slice(&(v as u16).to_le_bytes()),
                Int16 => b[..2].copy_from_slice(&(v as i16).to_le_bytes()),
                Uint32 | Uint64 => b = (v as u32).to_le_bytes(),
                Int32 | Int64 => b = (v as i32).to_le_bytes(),
                Real32 | Real64 => unreachable!(),
            }
            f32::from_le_bytes(b)
        }
    }
}

/// True when `a` and `b` are the same value once carried in a PARAM_SET of type `t` (what the
/// vehicle can echo back): reals compared as `f32`, integers exactly.
pub fn same(a: f64, b: f64, t: ParamType) -> bool {
    if t.is_integer() {
        a == b
    } else {
        (a as f32).to_bits() == (b as f32).to_bits() || (a as f32) == (b as f32)
    }
}

/// A value as people read it: integers without a fraction; reals in the shortest form that
/// reads back to the same `f32` (0.3, not 0.30000001).
pub fn format(v: f64, t: ParamType) -> String {
    if t.is_integer() {
        fmt_plain(v)
    } else if t == ParamType::Real64 {
        format!("{v}")
    } else {
        format!("{}", v as f32)
    }
}

/// A number without a needless fraction (`5`, `-3`, `0.25`).
pub fn fmt_plain(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e18 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytewise_int32_is_the_floats_bits() {
        // PX4 sends INT32 1 as the float with bit pattern 0x00000001 (a denormal).
        let f = f32::from_bits(1);
        assert_eq!(decode(f, ParamType::Int32, Encoding::Bytewise), 1.0);
        assert_eq!(
            encode(1.0, ParamType::Int32, Encoding::Bytewise).to_bits(),
            1
        );
        let f = f32::from_bits((-7i32) as u32);
        assert_eq!(decode(f, ParamType::Int32, Encoding::Bytewise), -7.0);
        // C cast: the float is the number.
        assert_eq!(decode(1.0, ParamType::Int32, Encoding::CCast), 1.0);
        assert_eq!(encode(1.0, ParamType::Int32, Encoding::CCast), 1.0);
        // Small types in the low bytes.
        let f = encode(-2.0, ParamType::Int8, Encoding::Bytewise);
        assert_eq!(f.to_bits(), 0xFE);
        assert_eq!(decode(f, ParamType::Int8, Encoding::Bytewise), -2.0);
        let f = encode(40000.0, ParamType::Uint16, Encoding::Bytewise);
        assert_eq!(f.to_bits(), 40000);
    }

    #[test]
    fn c_cast_refuses_what_a_float_cannot_hold() {
        // 2^24 + 1 and 2^24 + 3 have no float of their own (IEEE 754 single: 24-bit significand).
        let e = carry_check(16_777_217.0, ParamType::Int32, Encoding::CCast).unwrap_err();
        assert!(e.contains("16777216"), "{e}");
        let e = carry_check(16_777_219.0, ParamType::Int32, Encoding::CCast).unwrap_err();
        assert!(e.contains("it would arrive as 16777220"), "{e}");
        assert!(carry_check(16_777_216.0, ParamType::Int32, Encoding::CCast).is_ok());
        assert!(carry_check(-16_777_216.0, ParamType::Int32, Encoding::CCast).is_ok());
        // Bytewise carries every INT32.
        for v in [16_777_217.0, i32::MAX as f64, i32::MIN as f64] {
            assert!(carry_check(v, ParamType::Int32, Encoding::Bytewise).is_ok());
        }
        assert!(carry_check(0.3, ParamType::Real32, Encoding::CCast).is_ok());
    }

    #[test]
    fn floats_no_c_cast_integer_can_be() {
        // Bytewise -1, INT32_MAX (NaN), 1 (denormal), 2^24+1 (a tiny fraction), INT32_MIN (-0).
        for v in [-1i32, i32::MAX, 1, 16_777_217, i32::MIN] {
            let f = f32::from_bits(v as u32);
            assert!(
                implausible(f, ParamType::Int32, Encoding::CCast).is_some(),
                "{v}"
            );
        }
        for f in [0.0f32, 5.0, -300.0, 16_777_216.0] {
            assert_eq!(implausible(f, ParamType::Int32, Encoding::CCast), None);
        }
        // 300 is no INT8; bytewise, an INT8 has nothing above its low byte.
        assert!(implausible(300.0, ParamType::Int8, Encoding::CCast).is_some());
        assert!(implausible(5.0, ParamType::Int8, Encoding::Bytewise).is_some());
        assert_eq!(
            implausible(f32::from_bits(0xFE), ParamType::Int8, Encoding::Bytewise),
            None
        );
        assert_eq!(
            implausible(f32::NAN, ParamType::Real32, Encoding::CCast),
            None
        );
    }

    #[test]
    fn formats_round_trip_shortest() {
        assert_eq!(format(0.3f32 as f64, ParamType::Real32), "0.3");
        assert_eq!(format(0.1f32 as f64, ParamType::Real32), "0.1");
        assert_eq!(format(5.0, ParamType::Real32), "5");
        assert_eq!(format(1500.0, ParamType::Int16), "1500");
        assert_eq!(format(-1.0, ParamType::Int8), "-1");
        assert_eq!(format(1e-7f32 as f64, ParamType::Real32), "0.0000001");
    }

    #[test]
    fn ranges_are_checked() {
        assert!(ParamType::Int8.check(127.0).is_ok());
        assert!(ParamType::Int8.check(128.0).is_err());
        assert!(ParamType::Uint8.check(-1.0).is_err());
        assert!(ParamType::Int16.check(1.5).is_err());
        assert!(ParamType::Real32.check(f64::NAN).is_err());
        assert!(ParamType::Real32.check(1e39).is_err());
        assert!(ParamType::Int32.check(2147483647.0).is_ok());
    }

    #[test]
    fn same_compares_as_sent() {
        assert!(same(0.3, 0.3f32 as f64, ParamType::Real32));
        assert!(!same(0.3, 0.31, ParamType::Real32));
        assert!(same(3.0, 3.0, ParamType::Int8));
    }
}
