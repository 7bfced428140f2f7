//! Serial line settings for Modbus RTU: the compact form `/dev/ttyUSB0:19200:8E1`, opening
//! the port with tokio-serial, and the RTU frame timing (Modbus over serial line V1.02,
//! 2.5.1.1: 3.5 character times of silence end a frame, fixed at 1.75 ms above 19200 baud).

use std::path::PathBuf;
use std::time::Duration;

pub use tokio_serial::{DataBits, Parity, StopBits};

/// The default speed of the Modbus serial line specification.
pub const DEFAULT_BAUD: u32 = 19200;

/// A serial port and its frame format.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SerialSettings {
    pub path: PathBuf,
    pub baud: u32,
    pub data_bits: DataBits,
    pub parity: Parity,
    pub stop_bits: StopBits,
}

/// Why a serial port could not be opened.
#[derive(Debug, thiserror::Error)]
#[error("cannot open serial port {path} at {baud} baud: {source}")]
pub struct OpenError {
    pub path: String,
    pub baud: u32,
    #[source]
    pub source: tokio_serial::Error,
}

impl SerialSettings {
    /// `PATH[:BAUD[:FRAME]]`, FRAME being data bits (5-8), parity (`N`, `E`, `O`) and stop
    /// bits (1, 2), e.g. `/dev/ttyUSB0:19200:8E1` or `/dev/ttyS1:9600`. Defaults: 19200 baud,
    /// 8E1 (the specification's default: even parity). Baud and frame are recognised from the
    /// end, so a path with colons (`/dev/serial/by-path/pci-0000:00:14.0-usb-0:1`) is kept
    /// whole unless it ends in something that reads as a baud rate; add `:19200` then.
    pub fn parse(text: &str) -> Result<SerialSettings, String> {
        let text = text.trim();
        let mut rest = text;
        let mut frame = None;
        let mut baud = None;
        if let Some((head, tail)) = rest.rsplit_once(':') {
            if let Some(f) = parse_frame(tail) {
                frame = Some(f);
                rest = head;
            } else if looks_like_frame(tail) {
                return Err(format!(
                    "serial `{text}`: frame `{tail}` is not valid; write data bits 5-8, \
                     parity N, E or O and stop bits 1 or 2, e.g. 8E1 or 8N2"
                ));
            }
        }
        if let Some((head, tail)) = rest.rsplit_once(':') {
            if !tail.is_empty() && tail.bytes().all(|b| b.is_ascii_digit()) {
                match tail.parse::<u32>() {
                    Ok(b) if (50..=4_000_000).contains(&b) => baud = Some(b),
                    _ => {
                        return Err(format!(
                            "serial `{text}`: baud rate `{tail}` is not valid; write a rate \
                             from 50 to 4000000, e.g. 19200"
                        ))
                    }
                }
                rest = head;
            } else if frame.is_some() {
                return Err(format!(
                    "serial `{text}`: `{tail}` is not a baud rate; write PATH:BAUD:FRAME, \
                     e.g. /dev/ttyUSB0:19200:8E1"
                ));
            }
        }
        if rest.is_empty() {
            return Err(format!(
                "serial `{text}`: no device path; write PATH[:BAUD[:FRAME]], e.g. \
                 /dev/ttyUSB0:19200:8E1"
            ));
        }
        let (data_bits, parity, stop_bits) =
            frame.unwrap_or((DataBits::Eight, Parity::Even, StopBits::One));
        Ok(SerialSettings {
            path: PathBuf::from(rest),
            baud: baud.unwrap_or(DEFAULT_BAUD),
            data_bits,
            parity,
            stop_bits,
        })
    }

    /// Opens the port for tokio (raw mode, the configured speed and frame). Call it inside a
    /// tokio runtime.
    pub fn open(&self) -> Result<tokio_serial::SerialStream, OpenError> {
        let path = self.path.to_string_lossy().into_owned();
        let builder = tokio_serial::new(path.clone(), self.baud)
            .data_bits(self.data_bits)
            .parity(self.parity)
            .stop_bits(self.stop_bits)
            .flow_control(tokio_serial::FlowControl::None);
        tokio_serial::SerialStream::open(&builder).map_err(|source| OpenError {
            path,
            baud: self.baud,
            source,
        })
    }

    /// Bits on the wire per character: start bit, data bits, parity bit, stop bits.
    pub fn char_bits(&self) -> u32 {
        let data = match self.data_bits {
            DataBits::Five => 5,
            DataBits::Six => 6,
            DataBits::Seven => 7,
            DataBits::Eight => 8,
        };
        let parity = u32::from(self.parity != Parity::None);
        let stop = match self.stop_bits {
            StopBits::One => 1,
            StopBits::Two => 2,
        };
        1 + data + parity + stop
    }

    /// The time one character takes on the wire.
    pub fn char_time(&self) -> Duration {
        Duration::from_nanos(
            u64::from(self.char_bits()) * 1_000_000_000 / u64::from(self.baud.max(1)),
        )
    }

    /// The silence that ends an RTU frame: 3.5 character times, 1.75 ms above 19200 baud.
    pub fn frame_gap(&self) -> Duration {
        if self.baud > 19200 {
            Duration::from_micros(1750)
        } else {
            self.char_time() * 7 / 2
        }
    }

    /// The longest silence allowed inside an RTU frame: 1.5 character times, 750 µs above
    /// 19200 baud.
    pub fn char_gap(&self) -> Duration {
        if self.baud > 19200 {
            Duration::from_micros(750)
        } else {
            self.char_time() * 3 / 2
        }
    }

    /// The compact form [`SerialSettings::parse`] reads.
    pub fn compact(&self) -> String {
        let data = match self.data_bits {
            DataBits::Five => '5',
            DataBits::Six => '6',
            DataBits::Seven => '7',
            DataBits::Eight => '8',
        };
        let parity = match self.parity {
            Parity::None => 'N',
            Parity::Even => 'E',
            Parity::Odd => 'O',
        };
        let stop = match self.stop_bits {
            StopBits::One => '1',
            StopBits::Two => '2',
        };
        format!("{}:{}:{data}{parity}{stop}", self.path.display(), self.baud)
    }
}

impl std::fmt::Display for SerialSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.compact())
    }
}

fn looks_like_frame(s: &str) -> bool {
    let b = s.as_bytes();
    b.len() == 3 && b[0].is_ascii_digit() && b[1].is_ascii_alphabetic() && b[2].is_ascii_digit()
}

fn parse_frame(s: &str) -> Option<(DataBits, Parity, StopBits)> {
    if !looks_like_frame(s) {
        return None;
    }
    let b = s.as_bytes();
    let data = match b[0] {
        b'5' => DataBits::Five,
        b'6' => DataBits::Six,
        b'7' => DataBits::Seven,
        b'8' => DataBits::Eight,
        _ => return None,
    };
    let parity = match b[1].to_ascii_uppercase() {
        b'N' => Parity::None,
        b'E' => Parity::Even,
        b'O' => Parity::Odd,
        _ => return None,
    };
    let stop = match b[2] {
        b'1' => StopBits::One,
        b'2' => StopBits::Two,
        _ => return None,
    };
    Some((data, parity, stop))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok(text: &str) -> SerialSettings {
        SerialSettings::parse(text).unwrap_or_else(|e| panic!("{text}: {e}"))
    }

    #[test]
    fn full_form() {
        let s = ok("/dev/ttyUSB0:9600:7O2");
        assert_eq!(s.path, PathBuf::from("/dev/ttyUSB0"));
        assert_eq!(s.baud, 9600);
        assert_eq!(
            (s.data_bits, s.parity, s.stop_bits),
            (DataBits::Seven, Parity::Odd, StopBits::Two)
        );
        assert_eq!(s.compact(), "/dev/ttyUSB0:9600:7O2");
    }

    #[test]
    fn defaults_are_19200_8e1() {
        let s = ok("/dev/ttyS0");
        assert_eq!(s.compact(), "/dev/ttyS0:19200:8E1");
        assert_eq!(ok("/dev/ttyS0:115200").compact(), "/dev/ttyS0:115200:8E1");
        assert_eq!(ok("/dev/ttyS0:8n1").compact(), "/dev/ttyS0:19200:8N1");
    }

    #[test]
    fn paths_with_colons_are_kept() {
        let p = "/dev/serial/by-path/pci-0000:00:14.0-usb-0:1.2-port0";
        assert_eq!(ok(p).path, PathBuf::from(p));
        assert_eq!(ok(&format!("{p}:9600:8N1")).path, PathBuf::from(p));
    }

    #[test]
    fn bad_forms_say_how_to_fix() {
        for (text, says) in [
            ("/dev/ttyS0:9600:9E1", "frame `9E1`"),
            ("/dev/ttyS0:9600:8X1", "frame `8X1`"),
            ("/dev/ttyS0:9600:8E3", "frame `8E3`"),
            ("/dev/ttyS0:0", "baud rate `0`"),
            ("/dev/ttyS0:fast:8E1", "`fast` is not a baud rate"),
            (":19200:8E1", "no device path"),
            ("", "no device path"),
        ] {
            let e = SerialSettings::parse(text).unwrap_err();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn frame_timing() {
        // 8E1 = 11 bits; at 9600 baud a character is 1145.8 µs, 3.5 of them 4010 µs.
        let s = ok("/dev/x:9600:8E1");
        assert_eq!(s.char_bits(), 11);
        assert_eq!(s.frame_gap().as_micros(), 4010);
        assert_eq!(s.char_gap().as_micros(), 1718);
        assert_eq!(ok("/dev/x:8N1").char_bits(), 10);
        let fast = ok("/dev/x:115200");
        assert_eq!(fast.frame_gap(), Duration::from_micros(1750));
        assert_eq!(fast.char_gap(), Duration::from_micros(750));
    }
}
