//! Reading fields from a message payload as it came on the wire.
//!
//! MAVLink 2 cuts the trailing zero bytes of a payload, so a field beyond the end of what came
//! is zero: every read here is bounds-safe and zero-extending, and none allocates. Enum fields
//! are read as their raw numbers, so a value newer than the dialect is kept as it came.

/// A payload as sent (possibly cut short), read field by field at byte offsets.
#[derive(Debug, Clone, Copy)]
pub struct Payload<'a>(pub &'a [u8]);

impl<'a> Payload<'a> {
    pub fn new(payload: &'a [u8]) -> Self {
        Payload(payload)
    }

    /// `N` bytes from `at`, zeros beyond the end.
    #[inline]
    pub fn bytes<const N: usize>(&self, at: usize) -> [u8; N] {
        // All there (the usual case): a copy of a known length, no call.
        if let Some(whole) = at.checked_add(N).and_then(|end| self.0.get(at..end)) {
            return whole.try_into().expect("N bytes");
        }
        let mut b = [0u8; N];
        if let Some(src) = self.0.get(at..) {
            let n = src.len().min(N);
            b[..n].copy_from_slice(&src[..n]);
        }
        b
    }
    pub fn u8(&self, at: usize) -> u8 {
        self.0.get(at).copied().unwrap_or(0)
    }
    pub fn u16(&self, at: usize) -> u16 {
        u16::from_le_bytes(self.bytes(at))
    }
    pub fn i16(&self, at: usize) -> i16 {
        i16::from_le_bytes(self.bytes(at))
    }
    pub fn u32(&self, at: usize) -> u32 {
        u32::from_le_bytes(self.bytes(at))
    }
    pub fn i32(&self, at: usize) -> i32 {
        i32::from_le_bytes(self.bytes(at))
    }
    pub fn u64(&self, at: usize) -> u64 {
        u64::from_le_bytes(self.bytes(at))
    }
    pub fn f32(&self, at: usize) -> f32 {
        f32::from_le_bytes(self.bytes(at))
    }
    /// A text field of `n` bytes at `at`: up to its first NUL, invalid UTF-8 replaced, trimmed.
    pub fn text(&self, at: usize, n: usize) -> String {
        let b = self.0.get(at..).unwrap_or(&[]);
        let b = &b[..b.len().min(n)];
        let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
        String::from_utf8_lossy(&b[..end]).trim().to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_beyond_the_end_read_as_zero() {
        let p = Payload(&[0x34, 0x12, 0x01]);
        assert_eq!(p.u16(0), 0x1234);
        assert_eq!(p.u32(0), 0x0001_1234);
        assert_eq!(p.u16(2), 1);
        assert_eq!(p.u8(3), 0);
        assert_eq!(p.u64(100), 0);
        assert_eq!(p.f32(usize::MAX), 0.0);
        assert_eq!(Payload(&[]).i16(0), 0);
    }

    #[test]
    fn text_stops_at_nul_and_at_the_end() {
        assert_eq!(Payload(b"ab\0cd").text(0, 5), "ab");
        assert_eq!(Payload(b"xabc").text(1, 16), "abc");
        assert_eq!(Payload(b"abc").text(9, 4), "");
    }
}
