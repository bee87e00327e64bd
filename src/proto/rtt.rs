//! A round-trip estimate, as TCP keeps one (RFC 6298): the smoothed round trip and its
//! variation, and a retransmission timeout from them.

use crate::clock::Micros;

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Rtt {
    /// Smoothed round trip and its mean deviation, once one is measured.
    est: Option<(Micros, Micros)>,
}

impl Rtt {
    /// Add a measured round trip (only of a request sent once: Karn's rule is the caller's).
    pub fn sample(&mut self, rtt: Micros) {
        self.est = Some(match self.est {
            None => (rtt, rtt / 2),
            Some((s, v)) => ((7 * s + rtt) / 8, (3 * v + s.abs_diff(rtt)) / 4),
        });
    }

    pub fn is_measured(&self) -> bool {
        self.est.is_some()
    }

    /// The timeout: `initial` until a round trip is measured, then srtt + 4 × rttvar within
    /// `min..=max`.
    pub fn rto(&self, initial: Micros, min: Micros, max: Micros) -> Micros {
        match self.est {
            None => initial,
            Some((s, v)) => (s + 4 * v).clamp(min, max),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follows_rfc6298() {
        let mut r = Rtt::default();
        assert_eq!(r.rto(1_000, 10, 5_000), 1_000);
        r.sample(100);
        // srtt 100, rttvar 50: 100 + 200.
        assert_eq!(r.rto(1_000, 10, 5_000), 300);
        r.sample(100);
        // rttvar (3 × 50 + 0) / 4 = 37: 100 + 148.
        assert_eq!(r.rto(1_000, 10, 5_000), 248);
        assert_eq!(r.rto(1_000, 400, 5_000), 400);
    }
}
