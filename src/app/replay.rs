//! Replay links (`tlog:`) in the core: what their status means for the link (a seek is a jump
//! in time, the end of the log takes the link down), and the operator's controls, by key or by
//! the `replay` command, which go to every replay link.

use super::links::{LinkState, ReplayView};
use super::{App, Effect};
use crate::clock::{Micros, SECOND};
use crate::link::replay::{clock_text, ReplayCmd, ReplaySpeed, ReplayStatus};
use crate::link::LinkId;
use crate::proto::vehicles::Pace;
use crate::wire::Severity;

/// The reason shown on a replay link whose log has ended.
pub const END_OF_LOG: &str = "end of log";

/// Seconds a seek key moves.
pub const SEEK_STEP: i64 = 10;

/// Usage of the `replay` command.
pub const USAGE: &str = "usage: replay pause|resume|step [N]|seek ±SECONDS|seek [H:]MM:SS|\
speed N|faster|slower (speed 1 = real time, 0 = as fast as possible)";

/// `SECONDS`, `MM:SS` or `H:MM:SS` (fractions of a second allowed in the last part).
fn parse_time(s: &str) -> Option<f64> {
    let mut total = 0.0;
    let parts: Vec<&str> = s.split(':').collect();
    if parts.len() > 3 {
        return None;
    }
    for (i, p) in parts.iter().enumerate() {
        let v: f64 = p
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && *v >= 0.0)?;
        if i > 0 && v >= 60.0 {
            return None;
        }
        total = total * 60.0 + v;
    }
    Some(total)
}

/// Parse the arguments of `replay`.
pub fn parse(rest: &str) -> Result<ReplayCmd, String> {
    let mut words = rest.split_whitespace();
    let sub = words.next().unwrap_or("");
    let arg = words.next();
    if words.next().is_some() {
        return Err(USAGE.into());
    }
    let cmd = match (sub, arg) {
        ("pause", None) => ReplayCmd::Pause,
        ("resume" | "play", None) => ReplayCmd::Resume,
        ("step", None) => ReplayCmd::Step(1),
        ("step", Some(n)) => match n.parse::<u32>() {
            Ok(n @ 1..) => ReplayCmd::Step(n),
            _ => return Err(format!("replay step N: N is a count of frames, not `{n}`")),
        },
        ("seek", Some(t)) => {
            let bad = || format!("replay seek: `{t}` is not ±SECONDS or [H:]MM:SS");
            let (sign, body) = match t.as_bytes()[0] {
                b'+' => (1.0, &t[1..]),
                b'-' => (-1.0, &t[1..]),
                _ => (0.0, t),
            };
            let secs = parse_time(body).ok_or_else(bad)?;
            let us = (secs * SECOND as f64).round();
            if us > i64::MAX as f64 / 2.0 {
                return Err(bad());
            }
            if sign == 0.0 {
                ReplayCmd::SeekTo(us as Micros)
            } else {
                ReplayCmd::Seek((sign * us) as i64)
            }
        }
        ("speed", Some(v)) => ReplayCmd::Speed(v.parse::<ReplaySpeed>()?),
        ("faster", None) => ReplayCmd::Faster,
        ("slower", None) => ReplayCmd::Slower,
        _ => return Err(USAGE.into()),
    };
    Ok(cmd)
}

impl App {
    /// Links that are replays (they have told where they are).
    pub fn replay_links(&self) -> Vec<LinkId> {
        (0..self.links.len())
            .filter(|&i| self.links[i].replay.is_some())
            .collect()
    }

    /// The first replay link's view, for the status bar.
    pub fn replay_view(&self) -> Option<&ReplayView> {
        self.links.iter().find_map(|l| l.replay.as_ref())
    }

    /// Send `cmd` to every replay link; the text says what was asked.
    pub(super) fn replay_control(
        &mut self,
        cmd: ReplayCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<String, String> {
        let links = self.replay_links();
        if links.is_empty() {
            return Err("no replay link (tlog:FILE)".into());
        }
        for &link in &links {
            fx.push(Effect::ReplayControl { link, cmd });
        }
        let what = match cmd {
            ReplayCmd::TogglePause => "pause/resume".to_string(),
            ReplayCmd::Pause => "pause".into(),
            ReplayCmd::Resume => "resume".into(),
            ReplayCmd::Step(1) => "step one frame".into(),
            ReplayCmd::Step(n) => format!("step {n} frames"),
            ReplayCmd::Seek(d) => {
                let s = d.unsigned_abs() as f64 / SECOND as f64;
                format!("seek {}{s} s", if d < 0 { "-" } else { "+" })
            }
            ReplayCmd::SeekTo(t) => format!("seek to {}", clock_text(t, t >= 3600 * SECOND)),
            ReplayCmd::Speed(s) if s.is_max() => "speed: as fast as possible".into(),
            ReplayCmd::Speed(s) => format!("speed ×{}", s.get()),
            ReplayCmd::Faster => "faster".into(),
            ReplayCmd::Slower => "slower".into(),
        };
        Ok(format!("replay: {what}"))
    }

    /// A replay link said where it is.
    pub(super) fn on_replay_status(&mut self, link: LinkId, status: ReplayStatus) {
        let now: Micros = self.now;
        let Some(l) = self.links.get_mut(link) else {
            return;
        };
        let spec = l.spec.clone();
        let prev = l.replay.replace(ReplayView {
            status: status.clone(),
            at: now,
        });
        self.dirty = true;
        let (jumped, was_ended) = match &prev {
            Some(p) => (p.status.seeks != status.seeks, p.status.ended),
            None => (false, false),
        };
        // A paused replay's vehicles are not lost meanwhile, a slow one's judged in log time;
        // at the end of the log they go lost by the normal timeout.
        let pace = if status.ended {
            None
        } else if status.paused {
            Some(Pace::Held(now))
        } else if !status.speed.is_max() && status.speed.get() < 1.0 {
            Some(Pace::Slow(1.0 / status.speed.get()))
        } else {
            None
        };
        self.vehicles.set_pace(link, pace, now);
        if jumped {
            // What was skipped over is not loss, and boot times jump with the log.
            for s in l.sources.values_mut() {
                s.restart();
            }
            self.vehicles.on_time_jump(link);
        }
        if status.ended && !was_ended {
            // The link goes down, told once as what it is: not a failure.
            l.state = LinkState::Down(END_OF_LOG.into());
            l.notified_down = Some(END_OF_LOG.into());
            let long = status.duration.unwrap_or(status.position) >= 3600 * SECOND;
            self.notice(
                Severity::INFO,
                None,
                format!(
                    "end of log at {} on {spec}",
                    clock_text(status.position, long)
                ),
            );
        } else if !status.ended && was_ended {
            if l.state == LinkState::Down(END_OF_LOG.into()) {
                l.state = LinkState::Up;
                l.notified_down = None;
            }
            self.notice(Severity::INFO, None, format!("playing again: {spec}"));
        }
        if let Some(note) = status.note {
            self.notice(Severity::WARNING, None, format!("replay {spec}: {note}"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replay_commands_parse() {
        assert_eq!(parse("pause"), Ok(ReplayCmd::Pause));
        assert_eq!(parse("play"), Ok(ReplayCmd::Resume));
        assert_eq!(parse("step"), Ok(ReplayCmd::Step(1)));
        assert_eq!(parse("step 25"), Ok(ReplayCmd::Step(25)));
        assert_eq!(parse("seek -10"), Ok(ReplayCmd::Seek(-10 * SECOND as i64)));
        assert_eq!(parse("seek +2.5"), Ok(ReplayCmd::Seek(2_500_000)));
        assert_eq!(parse("seek 1:05"), Ok(ReplayCmd::SeekTo(65 * SECOND)));
        assert_eq!(parse("seek 1:00:05"), Ok(ReplayCmd::SeekTo(3605 * SECOND)));
        assert_eq!(
            parse("speed 4"),
            Ok(ReplayCmd::Speed(ReplaySpeed::new(4.0).unwrap()))
        );
        assert_eq!(parse("speed 0"), Ok(ReplayCmd::Speed(ReplaySpeed::MAX)));
        for bad in [
            "",
            "jump",
            "pause now",
            "seek",
            "seek 1:70",
            "seek x",
            "step 0",
        ] {
            assert!(parse(bad).is_err(), "{bad}");
        }
        assert!(parse("speed -2").unwrap_err().contains("speed `-2`"));
    }
}
