//! Connection strings (`--link`) parsed into a typed [`LinkSpec`].
//!
//! Accepted forms (MAVProxy's and MAVSDK's, so operators can paste what they already use):
//! `udpin:ADDR:PORT`, `udp:ADDR:PORT` (same as udpin), `udpout:HOST:PORT`, `tcp:HOST:PORT`,
//! `tcpin:ADDR:PORT`, `serial:PATH[:BAUD]`, `PATH,BAUD`, a bare `/dev/...` or `COMn` path,
//! `udp://[HOST]:PORT` (listen), `udpout://HOST:PORT`, `tcp://HOST:PORT`, `serial://PATH[:BAUD]`,
//! `sim://[?options]` and `tlog:PATH` (replay a recorded file).
//!
//! How a spec is read:
//! - A known scheme (`udpin:`, `tcp://`, `tlog:`, ...) decides first; the rest is that scheme's
//!   and nothing else's: `tlog:logs/a,b.tlog` is a file with a comma in its name.
//! - MAVProxy's `PATH,BAUD` applies to scheme-less specs (`/dev/ttyUSB0,57600`), and, as a
//!   convenience, inside `serial:` too: `serial:/dev/ttyS0,57600` is `/dev/ttyS0` at 57600 baud,
//!   the same as `serial:/dev/ttyS0:57600`.
//! - A serial path keeps its commas and colons unless what follows the last one is a baud rate
//!   (digits): `/dev/serial/by-id/usb-X,Y-if00:115200` is the device `.../usb-X,Y-if00`, and
//!   `/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0` is a path. A plain word there
//!   (`/dev/ttyUSB0,fast`) is refused as a bad baud rate.
//! - IPv6 addresses go in brackets (`udpin:[::]:14550`); unbracketed ones are refused with the
//!   bracketed form as a hint, since `udpin:::14550` cannot be told apart from a host `:`.
//! - `tlog:` needs a path.
//! - Network and serial links take options after `?`: `hl=1` marks a high-latency or
//!   low-bandwidth link (a satellite modem, a long-range radio), on which mavterm sends nothing
//!   on its own but its heartbeat: no stream requests, no parameter download, no mission
//!   traffic (`udpin:0.0.0.0:14550?hl=1`, `serial:/dev/ttyUSB0:57600?hl=1`); `secure=1` marks a
//!   link nobody else can reach (a USB cable, a wire): MAVLink signing keys go only on such a
//!   link, and unsigned frames are accepted on it (`serial:/dev/ttyACM0?secure=1`). Options join
//!   with `&`. `sim://` keeps its own options after `?`.
//! - `tlog:PATH?speed=N` replays at N times real time (1 by default; 0 = as fast as possible).
//!   The last `?` starts the options when what follows it reads as options (`key=value` words);
//!   otherwise it is part of the path (`tlog:what?.tlog`). A path whose `?` is followed by
//!   something that reads as options is written with a `?` at the end: `tlog:a?b=1.tlog?`.
//! - A serial spec remembers whether its baud was given: only a baud the operator wrote says how
//!   fast the link is (a USB port ignores it, a radio's UART does not), so only then are telemetry
//!   rates fitted to it.

use std::fmt;
use std::net::Ipv6Addr;
use std::str::FromStr;

use super::replay::ReplaySpeed;

/// Baud rate used when a serial spec names none (the usual telemetry-radio rate).
pub const DEFAULT_BAUD: u32 = 57_600;

/// The list printed with every parse error.
pub const ACCEPTED_FORMS: &str =
    "accepted forms: udpin:ADDR:PORT, udpout:HOST:PORT, tcp:HOST:PORT, \
tcpin:ADDR:PORT, serial:PATH[:BAUD], PATH,BAUD, udp://[HOST]:PORT, udpout://HOST:PORT, \
tcp://HOST:PORT, serial://PATH[:BAUD], sim://[?vehicles=N&...], tlog:PATH[?speed=N]; \
network and serial links take ?hl=1 (high latency: nothing sent but the heartbeat) and \
?secure=1 (a USB cable or a wire: signing keys may go on it)";

/// A link as the operator asked for it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkSpec {
    /// Listen for UDP; replies go to every peer heard, most recent first.
    UdpIn {
        addr: String,
        port: u16,
        hl: bool,
        secure: bool,
    },
    /// Send UDP to a fixed peer (and take what comes back).
    UdpOut {
        host: String,
        port: u16,
        hl: bool,
        secure: bool,
    },
    /// TCP client.
    TcpClient {
        host: String,
        port: u16,
        hl: bool,
        secure: bool,
    },
    /// TCP server accepting several clients.
    TcpServer {
        addr: String,
        port: u16,
        hl: bool,
        secure: bool,
    },
    /// Serial port; `baud` is `None` when the spec named none ([`DEFAULT_BAUD`] is used).
    Serial {
        path: String,
        baud: Option<u32>,
        hl: bool,
        secure: bool,
    },
    /// The embedded simulated vehicle(s); `query` is the text after `?`.
    Sim { query: String },
    /// Replay of a tlog file at a speed (1 = real time, 0 = as fast as possible).
    Tlog { path: String, speed: ReplaySpeed },
}

/// Why a connection string was refused. Each message names the part that is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SpecError {
    #[error("empty link spec; {ACCEPTED_FORMS}")]
    Empty,
    #[error("link spec `{input}`: unknown scheme `{scheme}`; {ACCEPTED_FORMS}")]
    UnknownScheme { input: String, scheme: String },
    #[error("link spec `{input}`: missing `:PORT` after `{host}`; {ACCEPTED_FORMS}")]
    MissingPort { input: String, host: String },
    #[error(
        "link spec `{input}`: port `{port}` is not a number from 1 to 65535; {ACCEPTED_FORMS}"
    )]
    BadPort { input: String, port: String },
    #[error("link spec `{input}`: missing host before `:{port}`; {ACCEPTED_FORMS}")]
    MissingHost { input: String, port: u16 },
    #[error("link spec `{input}`: baud `{baud}` is not a positive number; {ACCEPTED_FORMS}")]
    BadBaud { input: String, baud: String },
    #[error("link spec `{input}`: missing serial device path; {ACCEPTED_FORMS}")]
    MissingPath { input: String },
    #[error(
        "link spec `{input}`: an IPv6 address must be in brackets, e.g. `{hint}`; {ACCEPTED_FORMS}"
    )]
    Ipv6NeedsBrackets { input: String, hint: String },
    #[error(
        "link spec `{input}`: host `{host}` is not a host name or address (an IPv6 address \
         goes in brackets: [ADDR]:PORT); {ACCEPTED_FORMS}"
    )]
    BadHost { input: String, host: String },
    #[error("link spec `{input}`: missing file path after `tlog:`, e.g. tlog:flight.tlog")]
    MissingTlogPath { input: String },
    #[error("link spec `{input}`: option `{option}` is not known (link options: hl=1, secure=1)")]
    BadOption { input: String, option: String },
    #[error(
        "link spec `{input}`: option `{option}` is not known (tlog options: speed=N, 1 = real \
         time, 0 = as fast as possible; a path holding `?` ends with `?`: tlog:a?b=1.tlog?)"
    )]
    BadTlogOption { input: String, option: String },
    #[error("link spec `{input}`: {message}")]
    BadSpeed { input: String, message: String },
}

impl LinkSpec {
    /// True for links that carry datagrams (frames never span two reads).
    pub fn is_datagram(&self) -> bool {
        matches!(self, LinkSpec::UdpIn { .. } | LinkSpec::UdpOut { .. })
    }

    /// True for a link marked `?hl=1`: high latency or low bandwidth, nothing automatic on it.
    pub fn high_latency(&self) -> bool {
        match self {
            LinkSpec::UdpIn { hl, .. }
            | LinkSpec::UdpOut { hl, .. }
            | LinkSpec::TcpClient { hl, .. }
            | LinkSpec::TcpServer { hl, .. }
            | LinkSpec::Serial { hl, .. } => *hl,
            LinkSpec::Sim { .. } | LinkSpec::Tlog { .. } => false,
        }
    }

    /// True for a link marked `?secure=1`: a wire nobody else can reach (USB, a cable). Signing
    /// keys (SETUP_SIGNING) go only on such a link, and unsigned frames are accepted on it.
    pub fn secure(&self) -> bool {
        match self {
            LinkSpec::UdpIn { secure, .. }
            | LinkSpec::UdpOut { secure, .. }
            | LinkSpec::TcpClient { secure, .. }
            | LinkSpec::TcpServer { secure, .. }
            | LinkSpec::Serial { secure, .. } => *secure,
            LinkSpec::Sim { .. } | LinkSpec::Tlog { .. } => false,
        }
    }

    /// True for links that run in-process (`sim://`, `tlog:`): nothing from outside reaches
    /// them, so their frames are trusted like a secure link's.
    pub fn in_process(&self) -> bool {
        matches!(self, LinkSpec::Sim { .. } | LinkSpec::Tlog { .. })
    }

    /// The baud rate a serial spec names, if it names one.
    pub fn explicit_baud(&self) -> Option<u32> {
        match self {
            LinkSpec::Serial { baud, .. } => *baud,
            _ => None,
        }
    }

    /// The baud rate to open a serial port at.
    pub fn baud(&self) -> u32 {
        self.explicit_baud().unwrap_or(DEFAULT_BAUD)
    }
}

impl fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fn hp(h: &str) -> String {
            if h.contains([':', '%']) {
                format!("[{h}]")
            } else {
                h.to_string()
            }
        }
        match self {
            LinkSpec::UdpIn { addr, port, .. } => write!(f, "udpin:{}:{port}", hp(addr))?,
            LinkSpec::UdpOut { host, port, .. } => write!(f, "udpout:{}:{port}", hp(host))?,
            LinkSpec::TcpClient { host, port, .. } => write!(f, "tcp:{}:{port}", hp(host))?,
            LinkSpec::TcpServer { addr, port, .. } => write!(f, "tcpin:{}:{port}", hp(addr))?,
            LinkSpec::Serial { path, baud, .. } => {
                // A path that starts with `//` would read as the URL form: spell that out.
                let sep = if path.starts_with("//") { "//" } else { "" };
                write!(f, "serial:{sep}{path}")?;
                if let Some(b) = baud {
                    write!(f, ":{b}")?;
                }
            }
            LinkSpec::Sim { query } if query.is_empty() => write!(f, "sim://")?,
            LinkSpec::Sim { query } => write!(f, "sim://?{query}")?,
            LinkSpec::Tlog { path, speed } => {
                let sep = if path.starts_with("//") { "//" } else { "" };
                write!(f, "tlog:{sep}{path}")?;
                // A path holding `?` ends with one, so what follows it is not read as options.
                if *speed != ReplaySpeed::REAL_TIME {
                    write!(f, "?speed={speed}")?;
                } else if path.contains('?') {
                    write!(f, "?")?;
                }
            }
        }
        match (self.high_latency(), self.secure()) {
            (true, true) => write!(f, "?hl=1&secure=1")?,
            (true, false) => write!(f, "?hl=1")?,
            (false, true) => write!(f, "?secure=1")?,
            (false, false) => {}
        }
        Ok(())
    }
}

fn parse_port(input: &str, port: &str) -> Result<u16, SpecError> {
    match port.parse::<u16>() {
        Ok(p) if p > 0 && port.bytes().all(|b| b.is_ascii_digit()) => Ok(p),
        _ => Err(SpecError::BadPort {
            input: input.into(),
            port: port.into(),
        }),
    }
}

/// Split `HOST:PORT` (HOST may be `[v6]`, or empty when `allow_empty_host`). `prefix` is what
/// came before `rest` in the spec (`udpin:`), for the bracketed hint.
fn host_port(
    input: &str,
    prefix: &str,
    rest: &str,
    allow_empty_host: bool,
) -> Result<(String, u16), SpecError> {
    let (host, port) = if let Some(stripped) = rest.strip_prefix('[') {
        match stripped.split_once(']') {
            Some((h, p)) => match p.strip_prefix(':') {
                Some(p) => (h.to_string(), p),
                None => {
                    return Err(SpecError::MissingPort {
                        input: input.into(),
                        host: format!("[{h}]"),
                    })
                }
            },
            None => {
                return Err(SpecError::MissingPort {
                    input: input.into(),
                    host: rest.into(),
                })
            }
        }
    } else {
        match rest.rsplit_once(':') {
            Some((h, p)) if h.contains(':') => {
                // `udpin:::14550`, `tcp:fe80::1:5760`: IPv6 without brackets. The last colon is
                // taken for the port; `::` written as `:` before it is the usual slip.
                let v6 = |a: &str| {
                    a.split('%')
                        .next()
                        .unwrap_or("")
                        .parse::<Ipv6Addr>()
                        .is_ok()
                };
                let guess = if !v6(h) && v6(&format!("{h}:")) {
                    format!("{h}:")
                } else {
                    h.to_string()
                };
                if !v6(&guess) {
                    return Err(SpecError::BadHost {
                        input: input.into(),
                        host: h.into(),
                    });
                }
                let port = if p.is_empty() { "PORT" } else { p };
                return Err(SpecError::Ipv6NeedsBrackets {
                    input: input.into(),
                    hint: format!("{prefix}[{guess}]:{port}"),
                });
            }
            Some((h, p)) => (h.to_string(), p),
            None => {
                return Err(SpecError::MissingPort {
                    input: input.into(),
                    host: rest.into(),
                })
            }
        }
    };
    let port = parse_port(input, port)?;
    // Names, IPv4 and (in brackets) IPv6 addresses with an optional `%zone`.
    let bracketed = rest.starts_with('[');
    let allowed = |c: char| {
        c.is_alphanumeric() || matches!(c, '-' | '.' | '_') || (bracketed && matches!(c, ':' | '%'))
    };
    if !host.chars().all(allowed) {
        return Err(SpecError::BadHost {
            input: input.into(),
            host,
        });
    }
    if host.is_empty() {
        if allow_empty_host {
            return Ok(("0.0.0.0".into(), port));
        }
        return Err(SpecError::MissingHost {
            input: input.into(),
            port,
        });
    }
    Ok((host, port))
}

/// `PATH[:BAUD]` or `PATH,BAUD`. What follows the last `:` or `,` is a baud rate when it is
/// digits, a mistyped one when it is a plain word (letters and digits), and part of the path
/// otherwise (by-id and by-path device names hold commas, colons, dashes and dots).
fn serial(input: &str, rest: &str) -> Result<LinkSpec, SpecError> {
    let bad_baud = |b: &str| SpecError::BadBaud {
        input: input.into(),
        baud: b.into(),
    };
    let mut path = rest;
    let mut baud = None;
    for sep in [':', ','] {
        let Some((p, b)) = rest.rsplit_once(sep) else {
            continue;
        };
        if b.is_empty() {
            return Err(bad_baud(b));
        }
        if b.bytes().all(|c| c.is_ascii_digit()) {
            match b.parse::<u32>() {
                Ok(v) if v > 0 => {
                    path = p;
                    baud = Some(v);
                    break;
                }
                _ => return Err(bad_baud(b)),
            }
        }
        if b.bytes().all(|c| c.is_ascii_alphanumeric()) {
            return Err(bad_baud(b));
        }
    }
    if path.is_empty() {
        return Err(SpecError::MissingPath {
            input: input.into(),
        });
    }
    Ok(LinkSpec::Serial {
        path: path.into(),
        baud,
        hl: false,
        secure: false,
    })
}

/// The link options a spec may end with.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct LinkOptions {
    hl: bool,
    secure: bool,
}

/// `REST?OPTIONS` split: the options read (`hl=1`, `secure=1`), the rest returned. Options are
/// `key=value` pairs joined by `&`; each takes 1/0/true/false/yes/no (alone, it is `=1`).
fn options<'a>(input: &str, rest: &'a str) -> Result<(&'a str, LinkOptions), SpecError> {
    let Some((before, query)) = rest.split_once('?') else {
        return Ok((rest, LinkOptions::default()));
    };
    let mut o = LinkOptions::default();
    for opt in query.split('&').filter(|o| !o.is_empty()) {
        let (k, v) = opt.split_once('=').unwrap_or((opt, "1"));
        let on = match v.to_ascii_lowercase().as_str() {
            "1" | "true" | "yes" => Some(true),
            "0" | "false" | "no" => Some(false),
            _ => None,
        };
        match (k.to_ascii_lowercase().as_str(), on) {
            ("hl", Some(on)) => o.hl = on,
            ("secure", Some(on)) => o.secure = on,
            _ => {
                return Err(SpecError::BadOption {
                    input: input.into(),
                    option: opt.into(),
                })
            }
        }
    }
    Ok((before, o))
}

/// True when `tail` (what follows a `?`) reads as options: `key[=value]` parts joined by `&`,
/// keys being words of letters.
fn looks_like_options(tail: &str) -> bool {
    tail.split('&').filter(|o| !o.is_empty()).all(|o| {
        let key = o.split_once('=').map_or(o, |(k, _)| k);
        !key.is_empty() && key.chars().all(|c| c.is_ascii_alphabetic() || c == '_')
    })
}

/// `tlog:PATH[?speed=N]`. The last `?` starts options when what follows it reads as options
/// ([`looks_like_options`]) or is empty; otherwise it is part of the path (`what?.tlog`). A path
/// whose `?` is followed by something that reads as options is written with a `?` at the end.
fn tlog(input: &str, rest: &str) -> Result<LinkSpec, SpecError> {
    let (path, query) = match rest.rsplit_once('?') {
        // Blanks before the options are not the path's (they would not print back).
        Some((path, tail)) if looks_like_options(tail) => (path.trim_end(), tail),
        _ => (rest, ""),
    };
    if path.trim().is_empty() {
        return Err(SpecError::MissingTlogPath {
            input: input.into(),
        });
    }
    let mut speed = ReplaySpeed::REAL_TIME;
    for opt in query.split('&').filter(|o| !o.is_empty()) {
        match opt.split_once('=') {
            Some((k, v)) if k.eq_ignore_ascii_case("speed") => {
                speed = v.parse().map_err(|message| SpecError::BadSpeed {
                    input: input.into(),
                    message,
                })?
            }
            _ => {
                return Err(SpecError::BadTlogOption {
                    input: input.into(),
                    option: opt.into(),
                })
            }
        }
    }
    Ok(LinkSpec::Tlog {
        path: path.into(),
        speed,
    })
}

/// The same spec with the options `o`.
fn with_options(spec: LinkSpec, o: LinkOptions) -> LinkSpec {
    let LinkOptions { hl, secure } = o;
    match spec {
        LinkSpec::UdpIn { addr, port, .. } => LinkSpec::UdpIn {
            addr,
            port,
            hl,
            secure,
        },
        LinkSpec::UdpOut { host, port, .. } => LinkSpec::UdpOut {
            host,
            port,
            hl,
            secure,
        },
        LinkSpec::TcpClient { host, port, .. } => LinkSpec::TcpClient {
            host,
            port,
            hl,
            secure,
        },
        LinkSpec::TcpServer { addr, port, .. } => LinkSpec::TcpServer {
            addr,
            port,
            hl,
            secure,
        },
        LinkSpec::Serial { path, baud, .. } => LinkSpec::Serial {
            path,
            baud,
            hl,
            secure,
        },
        other => other,
    }
}

/// `SCHEME` and what follows `SCHEME:`, if `s` starts with a URI scheme (a letter, then
/// letters, digits, `+`, `-`, `.`).
fn scheme_of(s: &str) -> Option<(&str, &str)> {
    let (scheme, rest) = s.split_once(':')?;
    let mut cs = scheme.chars();
    let first = cs.next()?;
    let ok = first.is_ascii_alphabetic()
        && cs.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'));
    ok.then_some((scheme, rest))
}

/// `COM3`, `com12`, optionally followed by `:BAUD` or `,BAUD`.
fn is_com_port(s: &str) -> bool {
    let name = s.split([':', ',']).next().unwrap_or("");
    match (name.get(..3), name.get(3..)) {
        (Some(com), Some(n)) => {
            com.eq_ignore_ascii_case("COM")
                && !n.is_empty()
                && n.bytes().all(|b| b.is_ascii_digit())
        }
        _ => false,
    }
}

/// A scheme-less spec ending in `,DIGITS`: MAVProxy's `PATH,BAUD`.
fn has_comma_baud(s: &str) -> bool {
    s.rsplit_once(',').is_some_and(|(p, b)| {
        !p.is_empty() && !b.is_empty() && b.bytes().all(|c| c.is_ascii_digit())
    })
}

impl FromStr for LinkSpec {
    type Err = SpecError;

    fn from_str(input: &str) -> Result<Self, Self::Err> {
        let s = input.trim();
        if s.is_empty() {
            return Err(SpecError::Empty);
        }
        // `sim://` has options of its own after `?`, and a tlog path may hold one.
        let own_query = scheme_of(s).is_some_and(|(scheme, after)| {
            let scheme = scheme.to_ascii_lowercase();
            scheme == "tlog" || (after.starts_with("//") && matches!(&*scheme, "sim" | "file"))
        });
        if own_query {
            return transport(input, s);
        }
        let (s, opts) = options(input, s)?;
        Ok(with_options(transport(input, s.trim_end())?, opts))
    }
}

/// A spec without link options.
fn transport(input: &str, s: &str) -> Result<LinkSpec, SpecError> {
    if let Some((scheme, after)) = scheme_of(s) {
        // `scheme://rest` (MAVSDK) or `scheme:rest` (MAVProxy).
        let rest = after.strip_prefix("//").unwrap_or(after);
        let prefix = &s[..s.len() - rest.len()];
        let url = rest.len() != after.len();
        let (hl, secure) = (false, false);
        match (scheme.to_ascii_lowercase().as_str(), url) {
            ("udpin" | "udp", _) => {
                let (addr, port) = host_port(input, prefix, rest, true)?;
                return Ok(LinkSpec::UdpIn {
                    addr,
                    port,
                    hl,
                    secure,
                });
            }
            ("udpout", _) => {
                let (host, port) = host_port(input, prefix, rest, false)?;
                return Ok(LinkSpec::UdpOut {
                    host,
                    port,
                    hl,
                    secure,
                });
            }
            ("tcp", _) => {
                let (host, port) = host_port(input, prefix, rest, false)?;
                return Ok(LinkSpec::TcpClient {
                    host,
                    port,
                    hl,
                    secure,
                });
            }
            ("tcpin", _) => {
                let (addr, port) = host_port(input, prefix, rest, true)?;
                return Ok(LinkSpec::TcpServer {
                    addr,
                    port,
                    hl,
                    secure,
                });
            }
            ("serial", _) => return serial(input, rest),
            ("sim", true) => {
                return Ok(LinkSpec::Sim {
                    query: rest.trim_start_matches('?').to_string(),
                })
            }
            ("tlog", _) | ("file", true) => {
                if rest.is_empty() {
                    return Err(SpecError::MissingTlogPath {
                        input: input.into(),
                    });
                }
                return tlog(input, rest);
            }
            _ if is_com_port(s) => return serial(input, s),
            _ => {
                return Err(SpecError::UnknownScheme {
                    input: input.into(),
                    scheme: scheme.into(),
                })
            }
        }
    }
    // Scheme-less: a device path, MAVProxy's `PATH` or `PATH,BAUD`.
    if s.starts_with('/') || is_com_port(s) || has_comma_baud(s) {
        return serial(input, s);
    }
    Err(SpecError::UnknownScheme {
        input: input.into(),
        scheme: s.into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(s: &str) -> LinkSpec {
        s.parse().unwrap_or_else(|e| panic!("{s}: {e}"))
    }

    #[test]
    fn mavproxy_forms() {
        assert_eq!(
            p("udpin:0.0.0.0:14550"),
            LinkSpec::UdpIn {
                addr: "0.0.0.0".into(),
                port: 14550,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("udpout:10.0.0.2:14550"),
            LinkSpec::UdpOut {
                host: "10.0.0.2".into(),
                port: 14550,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("tcp:127.0.0.1:5760"),
            LinkSpec::TcpClient {
                host: "127.0.0.1".into(),
                port: 5760,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("tcpin:0.0.0.0:5760"),
            LinkSpec::TcpServer {
                addr: "0.0.0.0".into(),
                port: 5760,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("serial:/dev/ttyUSB0"),
            LinkSpec::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: None,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("serial:/dev/ttyACM0:115200"),
            LinkSpec::Serial {
                path: "/dev/ttyACM0".into(),
                baud: Some(115200),
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("/dev/ttyUSB0,921600"),
            LinkSpec::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: Some(921600),
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("/dev/ttyS1"),
            LinkSpec::Serial {
                path: "/dev/ttyS1".into(),
                baud: None,
                hl: false,
                secure: false,
            }
        );
    }

    #[test]
    fn mavsdk_forms() {
        assert_eq!(
            p("udp://:14540"),
            LinkSpec::UdpIn {
                addr: "0.0.0.0".into(),
                port: 14540,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("udp://127.0.0.1:14540"),
            LinkSpec::UdpIn {
                addr: "127.0.0.1".into(),
                port: 14540,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("udpout://192.168.1.5:14550"),
            LinkSpec::UdpOut {
                host: "192.168.1.5".into(),
                port: 14550,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("tcp://localhost:5760"),
            LinkSpec::TcpClient {
                host: "localhost".into(),
                port: 5760,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("serial:///dev/ttyAMA0:57600"),
            LinkSpec::Serial {
                path: "/dev/ttyAMA0".into(),
                baud: Some(57600),
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("udpin:[::1]:14550"),
            LinkSpec::UdpIn {
                addr: "::1".into(),
                port: 14550,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(
            p("sim://?vehicles=3&seed=7"),
            LinkSpec::Sim {
                query: "vehicles=3&seed=7".into()
            }
        );
        assert_eq!(p("sim://").to_string(), "sim://");
    }

    #[test]
    fn display_round_trips() {
        for s in [
            "udpin:127.0.0.1:14550",
            "udpout:h:1",
            "tcp:h:2",
            "tcpin:0.0.0.0:3",
            "serial:/dev/x:57600",
            "sim://?vehicles=2",
            "udpin:[::1]:14550",
            "tlog:logs/a,b.tlog",
            "tcp:[fe81%eth0]:5760",
        ] {
            assert_eq!(p(s).to_string(), s);
        }
        // `//` at the start of a path is kept, not taken for the URL form.
        assert_eq!(p("tlog:////srv/x.tlog"), tlog("//srv/x.tlog"));
        assert_eq!(p("tlog:////srv/x.tlog").to_string(), "tlog:////srv/x.tlog");
    }

    #[test]
    fn errors_name_the_wrong_part() {
        let e = "udpin:127.0.0.1:99999".parse::<LinkSpec>().unwrap_err();
        assert!(e.to_string().contains("port `99999`"), "{e}");
        assert!(e.to_string().contains("accepted forms"), "{e}");
        let e = "bogus:1:2".parse::<LinkSpec>().unwrap_err();
        assert!(e.to_string().contains("unknown scheme `bogus`"), "{e}");
        let e = "tcp:5760".parse::<LinkSpec>().unwrap_err();
        assert!(matches!(e, SpecError::MissingPort { .. }), "{e}");
        let e = "tcp::5760".parse::<LinkSpec>().unwrap_err();
        assert!(matches!(e, SpecError::MissingHost { .. }), "{e}");
        let e = "/dev/ttyUSB0,fast".parse::<LinkSpec>().unwrap_err();
        assert!(e.to_string().contains("baud `fast`"), "{e}");
        let e = "serial:".parse::<LinkSpec>().unwrap_err();
        assert!(matches!(e, SpecError::MissingPath { .. }), "{e}");
        assert_eq!("".parse::<LinkSpec>().unwrap_err(), SpecError::Empty);
        let e = "udpin:127.0.0.1".parse::<LinkSpec>().unwrap_err();
        assert!(e.to_string().contains("missing `:PORT`"), "{e}");
    }

    fn serial_at(path: &str, baud: u32) -> LinkSpec {
        LinkSpec::Serial {
            path: path.into(),
            baud: Some(baud),
            hl: false,
            secure: false,
        }
    }

    /// A serial spec that names no baud.
    fn serial_default(path: &str) -> LinkSpec {
        LinkSpec::Serial {
            path: path.into(),
            baud: None,
            hl: false,
            secure: false,
        }
    }

    fn tlog(path: &str) -> LinkSpec {
        LinkSpec::Tlog {
            path: path.into(),
            speed: ReplaySpeed::REAL_TIME,
        }
    }

    #[test]
    fn the_scheme_reads_commas_first() {
        // A tlog path keeps its commas, even before digits.
        assert_eq!(p("tlog:logs/a,b.tlog"), tlog("logs/a,b.tlog"));
        assert_eq!(p("tlog:logs/f,57600"), tlog("logs/f,57600"));
        assert_eq!(p("tlog://logs/a,b.tlog"), tlog("logs/a,b.tlog"));
        // MAVProxy's comma baud is accepted inside serial: too.
        assert_eq!(
            p("serial:/dev/ttyS0,115200"),
            serial_at("/dev/ttyS0", 115200)
        );
        assert_eq!(p("serial:/dev/ttyS0,57600"), serial_at("/dev/ttyS0", 57600));
        assert_eq!(p("serial:///dev/ttyS0,9600"), serial_at("/dev/ttyS0", 9600));
        // Scheme-less PATH,BAUD.
        assert_eq!(p("/dev/ttyUSB0,921600"), serial_at("/dev/ttyUSB0", 921600));
        assert_eq!(p("ttyUSB0,19200"), serial_at("ttyUSB0", 19200));
        assert_eq!(p("COM3,115200"), serial_at("COM3", 115200));
        assert_eq!(p("COM3:115200"), serial_at("COM3", 115200));
        assert_eq!(p("com12"), serial_default("com12"));
        // Other schemes do not take a comma baud.
        let e = "udpin:0.0.0.0:14550,57600".parse::<LinkSpec>().unwrap_err();
        assert!(
            matches!(e, SpecError::BadPort { ref port, .. } if port == "14550,57600"),
            "{e}"
        );
    }

    #[test]
    fn device_names_with_commas_and_colons_stay_whole() {
        let by_id = "/dev/serial/by-id/usb-X,Y-if00";
        assert_eq!(p(&format!("{by_id}:115200")), serial_at(by_id, 115200));
        assert_eq!(p(by_id), serial_default(by_id));
        assert_eq!(p(&format!("serial:{by_id}")), serial_default(by_id));
        assert_eq!(p(&format!("{by_id},230400")), serial_at(by_id, 230400));
        let by_path = "/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0";
        assert_eq!(p(by_path), serial_default(by_path));
        assert_eq!(p(&format!("{by_path}:460800")), serial_at(by_path, 460800));
        // A plain word where the baud goes is a mistyped baud, not a path.
        for (spec, baud) in [
            ("/dev/ttyUSB0,fast", "fast"),
            ("/dev/ttyUSB0:fast", "fast"),
            ("serial:/dev/ttyS0,0", "0"),
            ("serial:/dev/ttyS0:99999999999", "99999999999"),
            ("/dev/ttyUSB0,", ""),
        ] {
            match spec.parse::<LinkSpec>() {
                Err(SpecError::BadBaud { baud: b, .. }) => assert_eq!(b, baud, "{spec}"),
                other => panic!("{spec}: {other:?}"),
            }
        }
    }

    #[test]
    fn ipv6_needs_brackets() {
        for (spec, hint) in [
            ("udpin:::14550", "udpin:[::]:14550"),
            ("udp:::1:14550", "udp:[::1]:14550"),
            ("tcp:fe80::1:5760", "tcp:[fe80::1]:5760"),
            ("udp://::1:14540", "udp://[::1]:14540"),
            ("tcpin:::", "tcpin:[::]:PORT"),
        ] {
            let e = spec.parse::<LinkSpec>().unwrap_err();
            assert_eq!(
                e,
                SpecError::Ipv6NeedsBrackets {
                    input: spec.into(),
                    hint: hint.into()
                }
            );
            assert!(e.to_string().contains(&format!("e.g. `{hint}`")), "{e}");
        }
        assert_eq!(
            p("udpin:[::]:14550"),
            LinkSpec::UdpIn {
                addr: "::".into(),
                port: 14550,
                hl: false,
                secure: false,
            }
        );
        assert_eq!(p("udpin:[::]:14550").to_string(), "udpin:[::]:14550");
        assert_eq!(
            p("tcp:[fe80::1%eth0]:5760"),
            LinkSpec::TcpClient {
                host: "fe80::1%eth0".into(),
                port: 5760,
                hl: false,
                secure: false,
            }
        );
        // A colon in something that is no IPv6 address is a bad host.
        let e = "tcp:localhost:5760:1".parse::<LinkSpec>().unwrap_err();
        assert!(
            matches!(e, SpecError::BadHost { ref host, .. } if host == "localhost:5760"),
            "{e}"
        );
    }

    #[test]
    fn tlog_speed_option() {
        let at = |path: &str, v: f64| LinkSpec::Tlog {
            path: path.into(),
            speed: ReplaySpeed::new(v).unwrap(),
        };
        assert_eq!(p("tlog:a.tlog?speed=2"), at("a.tlog", 2.0));
        assert_eq!(p("tlog:a.tlog?speed=0"), at("a.tlog", 0.0));
        assert_eq!(p("tlog:a.tlog?speed=0.25"), at("a.tlog", 0.25));
        assert_eq!(p("tlog:a.tlog?speed=1"), tlog("a.tlog"));
        assert_eq!(p("tlog:a.tlog?"), tlog("a.tlog"));
        assert_eq!(p("tlog:a.tlog \n?speed=2"), at("a.tlog", 2.0));
        assert_eq!(p("file:///tmp/a.tlog?speed=4"), at("/tmp/a.tlog", 4.0));
        // A `?` not followed by options is the path's own.
        assert_eq!(p("tlog:what?.tlog"), tlog("what?.tlog"));
        assert_eq!(p("tlog:what?.tlog?speed=2"), at("what?.tlog", 2.0));
        for (spec, shown) in [
            ("tlog:a.tlog?speed=2", "tlog:a.tlog?speed=2"),
            ("tlog:a.tlog?speed=0.5", "tlog:a.tlog?speed=0.5"),
            ("tlog:a.tlog?speed=1", "tlog:a.tlog"),
            ("tlog:what?.tlog", "tlog:what?.tlog?"),
            ("tlog:a?x=1.tlog?", "tlog:a?x=1.tlog?"),
            ("tlog:////srv/x.tlog?speed=0", "tlog:////srv/x.tlog?speed=0"),
        ] {
            let l = p(spec);
            assert_eq!(l.to_string(), shown, "{spec}");
            assert_eq!(p(shown), l, "{shown} round-trips");
        }
        for (spec, what) in [
            ("tlog:a.tlog?speed=-1", "speed `-1`"),
            ("tlog:a.tlog?speed=fast", "speed `fast`"),
            ("tlog:a.tlog?speed=", "speed ``"),
            ("tlog:a.tlog?speed=nan", "speed `nan`"),
            ("tlog:a.tlog?sped=2", "option `sped=2`"),
            ("tlog:a.tlog?speed=2&hl=1", "option `hl=1`"),
            ("tlog:a.tlog?loop", "option `loop`"),
        ] {
            let e = spec.parse::<LinkSpec>().unwrap_err();
            assert!(e.to_string().contains(what), "{spec}: {e}");
            assert!(e.to_string().contains(&format!("`{spec}`")), "{spec}: {e}");
        }
        let e = "tlog:?speed=2".parse::<LinkSpec>().unwrap_err();
        assert!(matches!(e, SpecError::MissingTlogPath { .. }), "{e}");
    }

    #[test]
    fn tlog_needs_a_path() {
        for spec in ["tlog:", "tlog://", "  tlog:  "] {
            let e = spec.parse::<LinkSpec>().unwrap_err();
            assert!(
                matches!(e, SpecError::MissingTlogPath { .. }),
                "{spec}: {e}"
            );
            assert!(e.to_string().contains("missing file path"), "{e}");
        }
        assert_eq!(p("tlog:a.tlog"), tlog("a.tlog"));
        assert_eq!(p("file:///tmp/a.tlog"), tlog("/tmp/a.tlog"));
    }

    #[test]
    fn ports_are_plain_digits() {
        for spec in ["udpin:1.2.3.4:+80", "tcp:h:0", "tcp:h:65536", "tcp:h:"] {
            let e = spec.parse::<LinkSpec>().unwrap_err();
            assert!(matches!(e, SpecError::BadPort { .. }), "{spec}: {e}");
        }
    }

    #[test]
    fn hosts_are_names_or_addresses() {
        for (spec, host) in [
            ("tcp:a,b:5760", "a,b"),
            ("tcp:[[x]:1", "[x"),
            ("udpout:a b:1", "a b"),
            ("tcp:h/x:1", "h/x"),
            ("tcp:h%1:1", "h%1"),
        ] {
            match spec.parse::<LinkSpec>() {
                Err(SpecError::BadHost { host: h, .. }) => assert_eq!(h, host, "{spec}"),
                other => panic!("{spec}: {other:?}"),
            }
        }
        for (spec, host) in [
            ("tcp:my_host-1.local:5760", "my_host-1.local"),
            ("tcp:10.0.0.2:5760", "10.0.0.2"),
            ("tcp:[fe80::1%eth0]:5760", "fe80::1%eth0"),
        ] {
            match p(spec) {
                LinkSpec::TcpClient { host: h, .. } => assert_eq!(h, host),
                other => panic!("{spec}: {other:?}"),
            }
        }
    }
    #[test]
    fn high_latency_option_on_every_transport() {
        for (spec, shown) in [
            ("udpin:0.0.0.0:14550?hl=1", "udpin:0.0.0.0:14550?hl=1"),
            ("udp://:14550?hl=1", "udpin:0.0.0.0:14550?hl=1"),
            ("udpout:10.0.0.2:14550?hl=1", "udpout:10.0.0.2:14550?hl=1"),
            ("tcp:host:5760?hl=1", "tcp:host:5760?hl=1"),
            ("tcp://host:5760?hl=true", "tcp:host:5760?hl=1"),
            ("tcpin:0.0.0.0:5760?hl", "tcpin:0.0.0.0:5760?hl=1"),
            (
                "serial:/dev/ttyUSB0:57600?hl=1",
                "serial:/dev/ttyUSB0:57600?hl=1",
            ),
            ("serial:/dev/ttyUSB0?hl=1", "serial:/dev/ttyUSB0?hl=1"),
            ("/dev/ttyUSB0,57600?hl=1", "serial:/dev/ttyUSB0:57600?hl=1"),
            ("COM3:115200?hl=1", "serial:COM3:115200?hl=1"),
            ("udpin:[::]:14550?hl=1", "udpin:[::]:14550?hl=1"),
        ] {
            let l = p(spec);
            assert!(l.high_latency(), "{spec}");
            assert_eq!(l.to_string(), shown, "{spec}");
            // Display round-trips.
            assert_eq!(p(shown), l, "{shown}");
        }
        for spec in [
            "tcp:h:1",
            "tcp:h:1?hl=0",
            "tcp:h:1?",
            "serial:/dev/x:9600?hl=false",
        ] {
            assert!(!p(spec).high_latency(), "{spec}");
        }
        assert_eq!(p("tcp:h:1?hl=0").to_string(), "tcp:h:1");
        assert_eq!(
            p("udpin:0.0.0.0:14550?hl=1"),
            LinkSpec::UdpIn {
                addr: "0.0.0.0".into(),
                port: 14550,
                hl: true,
                secure: false,
            }
        );
        // sim:// and tlog: keep what follows `?` as theirs.
        assert_eq!(
            p("sim://?hl=1"),
            LinkSpec::Sim {
                query: "hl=1".into()
            }
        );
        // A tlog path whose `?` is followed by what reads as options ends with `?`.
        assert_eq!(p("tlog:a?hl=1.tlog?"), tlog("a?hl=1.tlog"));
        assert!(matches!(
            "tlog:a?hl=1.tlog".parse::<LinkSpec>(),
            Err(SpecError::BadTlogOption { .. })
        ));
        assert!(!p("sim://?hl=1").high_latency());
        // Unknown options and values are refused, naming them.
        for (spec, opt) in [
            ("tcp:h:1?foo=1", "foo=1"),
            ("tcp:h:1?hl=2", "hl=2"),
            ("serial:/dev/x?baud=9600", "baud=9600"),
        ] {
            match spec.parse::<LinkSpec>() {
                Err(e @ SpecError::BadOption { .. }) => {
                    assert!(e.to_string().contains(&format!("`{opt}`")), "{e}")
                }
                other => panic!("{spec}: {other:?}"),
            }
        }
    }

    #[test]
    fn secure_option_marks_a_wire() {
        for (spec, shown, hl) in [
            (
                "serial:/dev/ttyACM0?secure=1",
                "serial:/dev/ttyACM0?secure=1",
                false,
            ),
            (
                "/dev/ttyACM0,115200?secure",
                "serial:/dev/ttyACM0:115200?secure=1",
                false,
            ),
            (
                "tcp:10.0.0.2:5760?secure=yes&hl=1",
                "tcp:10.0.0.2:5760?hl=1&secure=1",
                true,
            ),
            (
                "udpin:0.0.0.0:14550?secure=true",
                "udpin:0.0.0.0:14550?secure=1",
                false,
            ),
        ] {
            let l = p(spec);
            assert!(l.secure(), "{spec}");
            assert_eq!(l.high_latency(), hl, "{spec}");
            assert_eq!(l.to_string(), shown, "{spec}");
            assert_eq!(p(shown), l, "{shown} round-trips");
        }
        for spec in [
            "tcp:h:1",
            "tcp:h:1?secure=0",
            "serial:/dev/x?hl=1",
            "sim://?secure=1",
        ] {
            assert!(!p(spec).secure(), "{spec}");
        }
        assert!(p("sim://").in_process() && p("tlog:a.tlog").in_process());
        assert!(!p("tcp:h:1?secure=1").in_process());
        match "tcp:h:1?secure=2".parse::<LinkSpec>() {
            Err(e @ SpecError::BadOption { .. }) => {
                assert!(e.to_string().contains("secure=1"), "{e}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_serial_spec_knows_whether_its_baud_was_given() {
        for (spec, baud) in [
            ("serial:/dev/ttyUSB0", None),
            ("/dev/ttyUSB0", None),
            ("COM3", None),
            ("serial:/dev/ttyUSB0:57600", Some(57600)),
            ("/dev/ttyUSB0,57600", Some(57600)),
            ("serial:/dev/ttyUSB0:115200?hl=1", Some(115200)),
            ("tcp:h:1", None),
        ] {
            let l = p(spec);
            assert_eq!(l.explicit_baud(), baud, "{spec}");
            assert_eq!(l.baud(), baud.unwrap_or(DEFAULT_BAUD), "{spec}");
            assert_eq!(p(&l.to_string()), l, "{spec} round-trips");
        }
        // The default is not written back as if it had been given.
        assert_eq!(p("serial:/dev/ttyUSB0").to_string(), "serial:/dev/ttyUSB0");
        assert_eq!(
            p("serial:/dev/ttyUSB0:57600").to_string(),
            "serial:/dev/ttyUSB0:57600"
        );
    }
}
