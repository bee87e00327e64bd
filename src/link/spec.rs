//! Connection strings (`--link`) parsed into a typed [`LinkSpec`].
//!
//! Accepted forms (MAVProxy's and MAVSDK's, so operators can paste what they already use):
//! `udpin:ADDR:PORT`, `udp:ADDR:PORT` (same as udpin), `udpout:HOST:PORT`, `tcp:HOST:PORT`,
//! `tcpin:ADDR:PORT`, `serial:PATH[:BAUD]`, `PATH,BAUD`, a bare `/dev/...` or `COMn` path,
//! `udp://[HOST]:PORT` (listen), `udpout://HOST:PORT`, `tcp://HOST:PORT`, `serial://PATH[:BAUD]`,
//! `sim://[?options]` and `tlog:PATH` (replay a recorded file).

use std::fmt;
use std::str::FromStr;

/// Baud rate used when a serial spec names none (the usual telemetry-radio rate).
pub const DEFAULT_BAUD: u32 = 57_600;

/// The list printed with every parse error.
pub const ACCEPTED_FORMS: &str =
    "accepted forms: udpin:ADDR:PORT, udpout:HOST:PORT, tcp:HOST:PORT, \
tcpin:ADDR:PORT, serial:PATH[:BAUD], PATH,BAUD, udp://[HOST]:PORT, udpout://HOST:PORT, \
tcp://HOST:PORT, serial://PATH[:BAUD], sim://[?vehicles=N&...], tlog:PATH";

/// A link as the operator asked for it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkSpec {
    /// Listen for UDP; replies go to every peer heard, most recent first.
    UdpIn { addr: String, port: u16 },
    /// Send UDP to a fixed peer (and take what comes back).
    UdpOut { host: String, port: u16 },
    /// TCP client.
    TcpClient { host: String, port: u16 },
    /// TCP server accepting several clients.
    TcpServer { addr: String, port: u16 },
    /// Serial port.
    Serial { path: String, baud: u32 },
    /// The embedded simulated vehicle(s); `query` is the text after `?`.
    Sim { query: String },
    /// Replay of a tlog file.
    Tlog { path: String },
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
}

impl LinkSpec {
    /// True for links that carry datagrams (frames never span two reads).
    pub fn is_datagram(&self) -> bool {
        matches!(self, LinkSpec::UdpIn { .. } | LinkSpec::UdpOut { .. })
    }
}

impl fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fn hp(h: &str) -> String {
            if h.contains(':') {
                format!("[{h}]")
            } else {
                h.to_string()
            }
        }
        match self {
            LinkSpec::UdpIn { addr, port } => write!(f, "udpin:{}:{port}", hp(addr)),
            LinkSpec::UdpOut { host, port } => write!(f, "udpout:{}:{port}", hp(host)),
            LinkSpec::TcpClient { host, port } => write!(f, "tcp:{}:{port}", hp(host)),
            LinkSpec::TcpServer { addr, port } => write!(f, "tcpin:{}:{port}", hp(addr)),
            LinkSpec::Serial { path, baud } => write!(f, "serial:{path}:{baud}"),
            LinkSpec::Sim { query } if query.is_empty() => write!(f, "sim://"),
            LinkSpec::Sim { query } => write!(f, "sim://?{query}"),
            LinkSpec::Tlog { path } => write!(f, "tlog:{path}"),
        }
    }
}

fn parse_port(input: &str, port: &str) -> Result<u16, SpecError> {
    match port.parse::<u16>() {
        Ok(p) if p > 0 => Ok(p),
        _ => Err(SpecError::BadPort {
            input: input.into(),
            port: port.into(),
        }),
    }
}

/// Split `HOST:PORT` (HOST may be `[v6]` or empty when `allow_empty_host`).
fn host_port(input: &str, rest: &str, allow_empty_host: bool) -> Result<(String, u16), SpecError> {
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

fn serial(input: &str, rest: &str) -> Result<LinkSpec, SpecError> {
    // PATH[:BAUD] — a Windows `COM3` or a `/dev/...` path has no colon of its own.
    let (path, baud) = match rest.rsplit_once(':') {
        Some((p, b)) if !p.is_empty() => {
            let baud = match b.parse::<u32>() {
                Ok(v) if v > 0 => v,
                _ => {
                    return Err(SpecError::BadBaud {
                        input: input.into(),
                        baud: b.into(),
                    })
                }
            };
            (p, baud)
        }
        _ => (rest, DEFAULT_BAUD),
    };
    if path.is_empty() {
        return Err(SpecError::MissingPath {
            input: input.into(),
        });
    }
    Ok(LinkSpec::Serial {
        path: path.into(),
        baud,
    })
}

impl FromStr for LinkSpec {
    type Err = SpecError;

    fn from_str(input: &str) -> Result<Self, Self::Err> {
        let s = input.trim();
        if s.is_empty() {
            return Err(SpecError::Empty);
        }
        // MAVSDK URL forms first.
        if let Some((scheme, rest)) = s.split_once("://") {
            return match scheme {
                "udp" | "udpin" => {
                    let (addr, port) = host_port(input, rest, true)?;
                    Ok(LinkSpec::UdpIn { addr, port })
                }
                "udpout" => {
                    let (host, port) = host_port(input, rest, false)?;
                    Ok(LinkSpec::UdpOut { host, port })
                }
                "tcp" => {
                    let (host, port) = host_port(input, rest, false)?;
                    Ok(LinkSpec::TcpClient { host, port })
                }
                "tcpin" => {
                    let (addr, port) = host_port(input, rest, true)?;
                    Ok(LinkSpec::TcpServer { addr, port })
                }
                "serial" => serial(input, rest),
                "sim" => Ok(LinkSpec::Sim {
                    query: rest.trim_start_matches('?').to_string(),
                }),
                "tlog" | "file" => Ok(LinkSpec::Tlog { path: rest.into() }),
                other => Err(SpecError::UnknownScheme {
                    input: input.into(),
                    scheme: other.into(),
                }),
            };
        }
        // MAVProxy `PATH,BAUD`.
        if let Some((path, baud)) = s.split_once(',') {
            return serial(input, &format!("{path}:{baud}"));
        }
        if let Some((scheme, rest)) = s.split_once(':') {
            match scheme {
                "udpin" | "udp" => {
                    let (addr, port) = host_port(input, rest, true)?;
                    return Ok(LinkSpec::UdpIn { addr, port });
                }
                "udpout" => {
                    let (host, port) = host_port(input, rest, false)?;
                    return Ok(LinkSpec::UdpOut { host, port });
                }
                "tcp" => {
                    let (host, port) = host_port(input, rest, false)?;
                    return Ok(LinkSpec::TcpClient { host, port });
                }
                "tcpin" => {
                    let (addr, port) = host_port(input, rest, true)?;
                    return Ok(LinkSpec::TcpServer { addr, port });
                }
                "serial" => return serial(input, rest),
                "tlog" => return Ok(LinkSpec::Tlog { path: rest.into() }),
                _ => {}
            }
            if !s.starts_with('/') {
                return Err(SpecError::UnknownScheme {
                    input: input.into(),
                    scheme: scheme.into(),
                });
            }
        }
        if s.starts_with('/') || s.to_ascii_uppercase().starts_with("COM") {
            return serial(input, s);
        }
        Err(SpecError::UnknownScheme {
            input: input.into(),
            scheme: s.into(),
        })
    }
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
                port: 14550
            }
        );
        assert_eq!(
            p("udpout:10.0.0.2:14550"),
            LinkSpec::UdpOut {
                host: "10.0.0.2".into(),
                port: 14550
            }
        );
        assert_eq!(
            p("tcp:127.0.0.1:5760"),
            LinkSpec::TcpClient {
                host: "127.0.0.1".into(),
                port: 5760
            }
        );
        assert_eq!(
            p("tcpin:0.0.0.0:5760"),
            LinkSpec::TcpServer {
                addr: "0.0.0.0".into(),
                port: 5760
            }
        );
        assert_eq!(
            p("serial:/dev/ttyUSB0"),
            LinkSpec::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: 57600
            }
        );
        assert_eq!(
            p("serial:/dev/ttyACM0:115200"),
            LinkSpec::Serial {
                path: "/dev/ttyACM0".into(),
                baud: 115200
            }
        );
        assert_eq!(
            p("/dev/ttyUSB0,921600"),
            LinkSpec::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: 921600
            }
        );
        assert_eq!(
            p("/dev/ttyS1"),
            LinkSpec::Serial {
                path: "/dev/ttyS1".into(),
                baud: 57600
            }
        );
    }

    #[test]
    fn mavsdk_forms() {
        assert_eq!(
            p("udp://:14540"),
            LinkSpec::UdpIn {
                addr: "0.0.0.0".into(),
                port: 14540
            }
        );
        assert_eq!(
            p("udp://127.0.0.1:14540"),
            LinkSpec::UdpIn {
                addr: "127.0.0.1".into(),
                port: 14540
            }
        );
        assert_eq!(
            p("udpout://192.168.1.5:14550"),
            LinkSpec::UdpOut {
                host: "192.168.1.5".into(),
                port: 14550
            }
        );
        assert_eq!(
            p("tcp://localhost:5760"),
            LinkSpec::TcpClient {
                host: "localhost".into(),
                port: 5760
            }
        );
        assert_eq!(
            p("serial:///dev/ttyAMA0:57600"),
            LinkSpec::Serial {
                path: "/dev/ttyAMA0".into(),
                baud: 57600
            }
        );
        assert_eq!(
            p("udpin:[::1]:14550"),
            LinkSpec::UdpIn {
                addr: "::1".into(),
                port: 14550
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
        ] {
            assert_eq!(p(s).to_string(), s);
        }
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
}
