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
