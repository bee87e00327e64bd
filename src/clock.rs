//! Time as the core sees it: a monotonic count of microseconds since the program (or replay)
//! started, handed in with every event. The core never reads a clock itself, so a replay on a
//! virtual clock is bit-for-bit deterministic.

/// Microseconds since start.
pub type Micros = u64;

pub const SECOND: Micros = 1_000_000;

/// Where a front end gets the time from.
pub trait Clock {
    fn now(&self) -> Micros;
}

/// Wall-clock time since the clock was made.
#[derive(Debug, Clone, Copy)]
pub struct RealClock(std::time::Instant);

impl RealClock {
    pub fn new() -> Self {
        RealClock(std::time::Instant::now())
    }
}

impl Default for RealClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for RealClock {
    fn now(&self) -> Micros {
        self.0.elapsed().as_micros() as Micros
    }
}

/// A clock that moves only when told: headless replay and tests.
#[derive(Debug, Default, Clone)]
pub struct VirtualClock(Micros);

impl VirtualClock {
    pub fn new() -> Self {
        VirtualClock(0)
    }
    pub fn set(&mut self, t: Micros) {
        self.0 = self.0.max(t);
    }
    pub fn advance(&mut self, d: Micros) {
        self.0 += d;
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> Micros {
        self.0
    }
}

/// How wall-clock times are shown: an offset from UTC and its name (`UTC`, or the offset as
/// `+05:30` for the local zone). Plain data: the edge resolves the local zone (`chrono::Local`,
/// for the instant the run starts at) and hands it to the core, which never reads the system's
/// time zone.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DisplayZone {
    pub offset: chrono::FixedOffset,
    pub label: String,
}

impl DisplayZone {
    /// UTC, labelled `UTC`.
    pub fn utc() -> Self {
        DisplayZone {
            offset: chrono::FixedOffset::east_opt(0).expect("0 is a valid offset"),
            label: "UTC".into(),
        }
    }

    /// A zone `offset` east of UTC, labelled with the offset (`+05:30`, `-04:00`).
    pub fn fixed(offset: chrono::FixedOffset) -> Self {
        DisplayZone {
            offset,
            label: offset.to_string(),
        }
    }

    /// `instant` in this zone.
    pub fn at(
        &self,
        instant: chrono::DateTime<chrono::Utc>,
    ) -> chrono::DateTime<chrono::FixedOffset> {
        instant.with_timezone(&self.offset)
    }
}

impl Default for DisplayZone {
    fn default() -> Self {
        Self::utc()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use chrono::{FixedOffset, TimeZone, Utc};

    #[test]
    fn a_zone_shows_an_instant_at_its_offset_and_names_it() {
        let t = Utc.with_ymd_and_hms(2026, 1, 1, 12, 0, 0).unwrap();
        let utc = DisplayZone::utc();
        assert_eq!(utc.label, "UTC");
        assert_eq!(utc.at(t).format("%H:%M:%S").to_string(), "12:00:00");
        let ist = DisplayZone::fixed(FixedOffset::east_opt(5 * 3600 + 1800).unwrap());
        assert_eq!(ist.label, "+05:30");
        assert_eq!(ist.at(t).format("%H:%M:%S").to_string(), "17:30:00");
        let ny = DisplayZone::fixed(FixedOffset::west_opt(5 * 3600).unwrap());
        assert_eq!(ny.label, "-05:00");
        assert_eq!(ny.at(t).format("%d %H:%M").to_string(), "01 07:00");
    }
}
