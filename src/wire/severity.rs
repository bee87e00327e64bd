//! How serious a message is: MAVLink's MAV_SEVERITY (RFC-5424), 0 = EMERGENCY … 7 = DEBUG. One
//! type for a vehicle's STATUSTEXT and mavterm's own notices alike. A value newer than the dialect
//! (above 7) is kept as sent.

use std::fmt;

/// A MAV_SEVERITY value; lower is more serious.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Severity(pub u8);

impl Severity {
    pub const EMERGENCY: Severity = Severity(0);
    pub const ALERT: Severity = Severity(1);
    pub const CRITICAL: Severity = Severity(2);
    pub const ERROR: Severity = Severity(3);
    pub const WARNING: Severity = Severity(4);
    pub const NOTICE: Severity = Severity(5);
    pub const INFO: Severity = Severity(6);
    pub const DEBUG: Severity = Severity(7);

    /// The short name the message log shows ("WARN"), `"?"` for a value newer than the dialect.
    pub fn name(self) -> &'static str {
        const NAMES: [&str; 8] = [
            "EMERG", "ALERT", "CRIT", "ERROR", "WARN", "NOTICE", "INFO", "DEBUG",
        ];
        NAMES.get(self.0 as usize).copied().unwrap_or("?")
    }
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl From<u8> for Severity {
    fn from(v: u8) -> Self {
        Severity(v)
    }
}

impl From<crate::dialect::MavSeverity> for Severity {
    fn from(v: crate::dialect::MavSeverity) -> Self {
        Severity(v as u8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_mav_severity_and_keep_newer_values() {
        // MAV_SEVERITY in common.xml: 4 = WARNING, 7 = DEBUG.
        assert_eq!(Severity(4).name(), "WARN");
        assert_eq!(Severity::DEBUG.0, 7);
        assert_eq!(Severity(9).name(), "?");
        assert!(Severity::ERROR < Severity::INFO);
    }
}
