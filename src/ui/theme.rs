//! Colours, or none: the [`Theme`] is chosen once at startup (`NO_COLOR`, see no-color.org) and
//! passed to every render call, so rendering itself never reads the environment and tests are
//! deterministic. Without colour, emphasis uses only bold/reverse/dim.

use ratatui::style::{Color, Modifier, Style};

use crate::wire::Severity;

/// How things look.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Theme {
    pub color: bool,
}

impl Default for Theme {
    fn default() -> Self {
        Theme { color: true }
    }
}

impl Theme {
    /// Monochrome.
    pub const PLAIN: Theme = Theme { color: false };

    /// Colour unless `NO_COLOR` is set to a non-empty value. Call once at startup.
    pub fn from_env() -> Theme {
        Theme::from_no_color(std::env::var_os("NO_COLOR"))
    }

    /// The decision behind [`Theme::from_env`], testable without touching the environment.
    pub fn from_no_color(value: Option<std::ffi::OsString>) -> Theme {
        Theme {
            color: value.is_none_or(|v| v.is_empty()),
        }
    }

    fn fg(&self, c: Color) -> Style {
        if self.color {
            Style::default().fg(c)
        } else {
            Style::default()
        }
    }

    pub fn border(&self) -> Style {
        self.fg(Color::DarkGray)
    }
    pub fn focus_border(&self) -> Style {
        self.fg(Color::Cyan).add_modifier(Modifier::BOLD)
    }
    pub fn header(&self) -> Style {
        self.fg(Color::Yellow).add_modifier(Modifier::BOLD)
    }
    pub fn selected(&self) -> Style {
        Style::default().add_modifier(Modifier::REVERSED)
    }
    /// Lost vehicles, idle things.
    pub fn dim(&self) -> Style {
        if self.color {
            Style::default().fg(Color::DarkGray)
        } else {
            Style::default().add_modifier(Modifier::DIM)
        }
    }
    /// Conflicts, link down, errors.
    pub fn alert(&self) -> Style {
        self.fg(Color::Red).add_modifier(Modifier::BOLD)
    }
    pub fn good(&self) -> Style {
        self.fg(Color::Green)
    }
    pub fn armed(&self) -> Style {
        self.fg(Color::Red).add_modifier(Modifier::BOLD)
    }
    /// mavterm's own notices' source column (`mavterm`), told apart from a vehicle's key.
    pub fn ours(&self) -> Style {
        if self.color {
            Style::default().fg(Color::LightBlue)
        } else {
            Style::default().add_modifier(Modifier::ITALIC)
        }
    }
    /// A message's severity: a vehicle's STATUSTEXT or mavterm's own.
    pub fn severity(&self, sev: Severity) -> Style {
        match sev {
            Severity::EMERGENCY | Severity::ALERT | Severity::CRITICAL => {
                self.fg(Color::Magenta).add_modifier(Modifier::BOLD)
            }
            Severity::ERROR => self.fg(Color::Red).add_modifier(Modifier::BOLD),
            Severity::WARNING => self.fg(Color::Yellow),
            Severity::NOTICE => self.fg(Color::Cyan),
            Severity::INFO => Style::default(),
            _ => self.dim(),
        }
    }
}
