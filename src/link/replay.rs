//! Replay controls and state, shared by the replay source (`tlog:`), the drivers that carry
//! commands to it, and the core that shows where a replay is.
//!
//! A replay keeps its own clock, the log's: record times relative to the first record. It is
//! mapped onto the clock it is run on (virtual or wall) by an anchor and a speed; pausing
//! freezes it, a new speed re-anchors it, a seek moves it.

use std::fmt;

use crate::clock::{Micros, SECOND};

/// How fast a replay plays: 1 = real time, 2 = twice as fast, 0 = as fast as the core takes
/// the frames. Never negative, never NaN.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct ReplaySpeed(f64);

impl Eq for ReplaySpeed {}

/// The fastest paced speed; `faster` from here is as fast as possible (speed 0).
pub const MAX_PACED_SPEED: f64 = 64.0;
/// The slowest speed `slower` goes to.
pub const MIN_SPEED: f64 = 1.0 / 16.0;
/// Largest speed accepted at all (a bigger number is surely a typo).
pub const MAX_SPEED: f64 = 10_000.0;

impl ReplaySpeed {
    /// Real time.
    pub const REAL_TIME: ReplaySpeed = ReplaySpeed(1.0);
    /// As fast as possible.
    pub const MAX: ReplaySpeed = ReplaySpeed(0.0);

    /// A speed from a number: finite, 0 to [`MAX_SPEED`].
    pub fn new(v: f64) -> Option<Self> {
        (v.is_finite() && (0.0..=MAX_SPEED).contains(&v)).then_some(ReplaySpeed(v))
    }

    /// The speed as a factor; 0 means as fast as possible.
    pub fn get(self) -> f64 {
        self.0
    }

    /// True for "as fast as possible".
    pub fn is_max(self) -> bool {
        self.0 == 0.0
    }

    /// Twice as fast, up to [`MAX_PACED_SPEED`]; from there, as fast as possible.
    pub fn faster(self) -> Self {
        if self.is_max() || self.0 >= MAX_PACED_SPEED {
            return Self::MAX;
        }
        ReplaySpeed((self.0 * 2.0).min(MAX_PACED_SPEED))
    }

    /// Half as fast, down to [`MIN_SPEED`]; as fast as possible becomes [`MAX_PACED_SPEED`].
    pub fn slower(self) -> Self {
        if self.is_max() {
            return ReplaySpeed(MAX_PACED_SPEED);
        }
        ReplaySpeed((self.0 / 2.0).max(MIN_SPEED))
    }
}

impl Default for ReplaySpeed {
    fn default() -> Self {
        Self::REAL_TIME
    }
}

impl fmt::Display for ReplaySpeed {
    /// `2`, `0.5`, `0` (as written in `?speed=`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl std::str::FromStr for ReplaySpeed {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        let s = s.strip_prefix(['x', '×']).unwrap_or(s);
        match s.to_ascii_lowercase().as_str() {
            "max" => return Ok(Self::MAX),
            "real" => return Ok(Self::REAL_TIME),
            _ => {}
        }
        s.parse::<f64>().ok().and_then(Self::new).ok_or_else(|| {
            format!(
                "speed `{s}` is not a number from 0 to {MAX_SPEED} \
                 (1 = real time, 2 = twice as fast, 0 = as fast as possible)"
            )
        })
    }
}

/// What the operator asks of a replay.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplayCmd {
    /// Pause if playing, play if paused.
    TogglePause,
    Pause,
    Resume,
    /// While paused (pausing first if needed): hand on the next `n` records now.
    Step(u32),
    /// Move by this much log time (µs, negative = back); nothing skipped over is handed on.
    Seek(i64),
    /// Move to this log time (µs since the first record).
    SeekTo(Micros),
    Speed(ReplaySpeed),
    /// Twice as fast ([`ReplaySpeed::faster`]).
    Faster,
    /// Half as fast ([`ReplaySpeed::slower`]).
    Slower,
}

/// Where a replay is, as its source tells the core: sent when something changes (pause, speed,
/// seek, step, end), not on a timer; while it plays, the position moves at `speed` from the time
/// it was sent. As fast as possible, it is sent at most about once a second.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayStatus {
    /// Log time now: µs since the log's first record.
    pub position: Micros,
    /// When the first record was recorded, µs since the Unix epoch (its tlog timestamp), when
    /// there is a record: log time `p` was recorded at `start + p`.
    pub start: Option<u64>,
    /// Log time of the last record, when known (a file; not a stream).
    pub duration: Option<Micros>,
    pub speed: ReplaySpeed,
    pub paused: bool,
    /// The last record has been handed on.
    pub ended: bool,
    /// Seeks so far: when it changes, the frames that follow do not continue the ones before.
    pub seeks: u32,
    /// Something to tell the operator (a seek that could not be done).
    pub note: Option<String>,
}

impl ReplayStatus {
    /// Log time at core time `now`, when this status was taken at core time `at`: it moves
    /// while playing at a paced speed, and stops at the end of the log.
    pub fn position_at(&self, at: Micros, now: Micros) -> Micros {
        if self.paused || self.ended || self.speed.is_max() {
            return self.position;
        }
        let moved = (now.saturating_sub(at) as f64 * self.speed.get()) as Micros;
        let p = self.position.saturating_add(moved);
        match self.duration {
            Some(d) if self.position <= d => p.min(d),
            _ => p,
        }
    }
}

/// `12:34` (under an hour) or `1:02:03`, for log times.
pub fn clock_text(t: Micros, long: bool) -> String {
    let s = t / SECOND;
    if long {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{:02}:{:02}", s / 60, s % 60)
    }
}

/// `×2`, `×0.5`, `×max`.
pub fn speed_text(speed: ReplaySpeed) -> String {
    if speed.is_max() {
        "×max".into()
    } else {
        format!("×{}", speed.get())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speeds_double_and_halve_within_bounds() {
        let s = ReplaySpeed::REAL_TIME;
        assert_eq!(s.faster().get(), 2.0);
        assert_eq!(s.slower().get(), 0.5);
        let mut f = s;
        for _ in 0..6 {
            f = f.faster();
        }
        assert_eq!(f.get(), 64.0);
        assert!(f.faster().is_max());
        assert_eq!(ReplaySpeed::MAX.slower().get(), 64.0);
        assert!(ReplaySpeed::MAX.faster().is_max());
        let mut sl = s;
        for _ in 0..10 {
            sl = sl.slower();
        }
        assert_eq!(sl.get(), MIN_SPEED);
        assert_eq!("2".parse::<ReplaySpeed>().unwrap().get(), 2.0);
        assert_eq!("x0.5".parse::<ReplaySpeed>().unwrap().get(), 0.5);
        assert!("max".parse::<ReplaySpeed>().unwrap().is_max());
        for bad in ["-1", "nan", "inf", "fast", "", "20000"] {
            let e = bad.parse::<ReplaySpeed>().unwrap_err();
            assert!(e.contains("1 = real time"), "{bad}: {e}");
        }
    }

    #[test]
    fn position_moves_at_speed_and_stops_at_the_end() {
        let st = ReplayStatus {
            position: 10 * SECOND,
            start: None,
            duration: Some(20 * SECOND),
            speed: ReplaySpeed::new(2.0).unwrap(),
            paused: false,
            ended: false,
            seeks: 0,
            note: None,
        };
        assert_eq!(st.position_at(5 * SECOND, 7 * SECOND), 14 * SECOND);
        assert_eq!(st.position_at(5 * SECOND, 60 * SECOND), 20 * SECOND);
        let paused = ReplayStatus {
            paused: true,
            ..st.clone()
        };
        assert_eq!(paused.position_at(5 * SECOND, 60 * SECOND), 10 * SECOND);
        assert_eq!(clock_text(83 * SECOND, false), "01:23");
        assert_eq!(clock_text(3723 * SECOND, true), "1:02:03");
    }
}
