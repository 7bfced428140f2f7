//! Modbus RTU on a serial line. A request is complete as soon as the bytes its function code
//! calls for (with a good CRC) are in, so answers do not wait for the line to go quiet; any
//! other bytes (an unknown function, a frame cut short, noise) are judged once the line has
//! been silent: one frame with a good CRC is answered (exception 01 or 03), anything else is
//! dropped. Frames for other slave addresses are ignored; broadcasts (address 0) are executed
//! without an answer.
//!
//! The specification's silence is 3.5 character times (2 ms at 19200 baud), but USB serial
//! adapters and pseudo-terminals deliver bytes in bursts with gaps longer than that inside a
//! frame. So bytes whose length is unknown are judged after at least [`MIN_SILENCE`], and the
//! rest of a frame whose length is known is awaited for up to [`BYTE_TIMEOUT`] (libmodbus
//! waits 0.5 s too) before it is dropped as noise.

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::SerialStream;

use crate::serial::SerialSettings;

use super::pdu;
use super::Shared;

/// The largest RTU frame: address, 253-byte PDU, CRC.
const MAX_FRAME: usize = 256;

/// The least silence that ends a frame of unknown length.
pub const MIN_SILENCE: Duration = Duration::from_millis(20);
/// How long the rest of a frame of known length is awaited.
pub const BYTE_TIMEOUT: Duration = Duration::from_millis(500);

/// Modbus CRC-16 (polynomial 0xA001 reflected, initial 0xFFFF); sent low byte first.
pub fn crc16(data: &[u8]) -> u16 {
    static TABLE: [u16; 256] = {
        let mut t = [0u16; 256];
        let mut i = 0;
        while i < 256 {
            let mut c = i as u16;
            let mut k = 0;
            while k < 8 {
                c = if c & 1 != 0 {
                    (c >> 1) ^ 0xA001
                } else {
                    c >> 1
                };
                k += 1;
            }
            t[i] = c;
            i += 1;
        }
        t
    };
    data.iter().fold(0xFFFF, |crc, &b| {
        (crc >> 8) ^ TABLE[usize::from((crc ^ u16::from(b)) as u8)]
    })
}

/// Whether `frame` ends with the CRC of what comes before it.
pub fn crc_ok(frame: &[u8]) -> bool {
    frame.len() >= 4 && {
        let (body, crc) = frame.split_at(frame.len() - 2);
        crc16(body).to_le_bytes() == [crc[0], crc[1]]
    }
}

/// How long a request starting at `buf[0]` is, as far as the bytes so far tell.
#[derive(Debug, PartialEq, Eq)]
pub enum Expect {
    /// More bytes are needed to tell.
    More,
    /// The whole frame is this long (address to CRC).
    Len(usize),
    /// A function code whose length we cannot know: wait for the line to go quiet.
    Silence,
}

pub fn expect(buf: &[u8]) -> Expect {
    let Some(&fc) = buf.get(1) else {
        return Expect::More;
    };
    match fc {
        0x01..=0x06 => Expect::Len(8),
        0x0F | 0x10 => buf
            .get(6)
            .map_or(Expect::More, |&n| Expect::Len(9 + usize::from(n))),
        0x17 => buf
            .get(10)
            .map_or(Expect::More, |&n| Expect::Len(13 + usize::from(n))),
        _ => Expect::Silence,
    }
}

pub(super) async fn serve(
    mut port: SerialStream,
    settings: SerialSettings,
    unit: u8,
    shared: Arc<Shared>,
) {
    let name = &shared.name;
    let silence = settings.frame_gap().max(MIN_SILENCE);
    let mut buf = [0u8; 2 * MAX_FRAME];
    let mut filled = 0usize;
    let mut out: Vec<u8> = Vec::with_capacity(MAX_FRAME);
    let mut failures = 0u32;
    loop {
        let wait = match expect(&buf[..filled]) {
            Expect::Len(n) if filled >= n => silence,
            Expect::Silence => silence,
            Expect::Len(_) | Expect::More => BYTE_TIMEOUT,
        };
        let read = port.read(&mut buf[filled..]);
        let got = if filled == 0 {
            read.await
        } else {
            match tokio::time::timeout(wait, read).await {
                Ok(r) => r,
                Err(_) => {
                    // The line went quiet: what is left is one frame or noise.
                    let frame = &buf[..filled];
                    if crc_ok(frame) {
                        answer(frame, unit, &shared, &mut out);
                        write(&mut port, &mut out, name).await;
                    } else {
                        log::debug!(
                            "modbus_server {name}: dropped {filled} bytes on the serial line \
                             (not a frame with a good CRC)"
                        );
                    }
                    filled = 0;
                    continue;
                }
            }
        };
        match got {
            Ok(n) if n > 0 => {
                failures = 0;
                filled += n;
            }
            other => {
                // A vanished device (USB adapter pulled) or a pty whose other side closed:
                // keep trying, without spinning, and say so once.
                if failures == 0 {
                    let why = match other {
                        Err(e) => e.to_string(),
                        Ok(_) => "end of file".to_string(),
                    };
                    log::warn!(
                        "modbus_server {name}: reading {}: {why}; retrying",
                        settings.path.display()
                    );
                }
                failures += 1;
                filled = 0;
                tokio::time::sleep(Duration::from_millis(200)).await;
                continue;
            }
        }
        // Answer every complete request at the front of the buffer.
        let mut pos = 0;
        while let Expect::Len(n) = expect(&buf[pos..filled]) {
            if filled - pos < n || !crc_ok(&buf[pos..pos + n]) {
                break;
            }
            answer(&buf[pos..pos + n], unit, &shared, &mut out);
            pos += n;
        }
        if pos > 0 {
            buf.copy_within(pos..filled, 0);
            filled -= pos;
            write(&mut port, &mut out, name).await;
        }
        if filled >= MAX_FRAME {
            // Longer than any frame: noise. Start again with what comes next.
            log::debug!("modbus_server {name}: dropped {filled} bytes of noise on the serial line");
            filled = 0;
        }
    }
}

async fn write(port: &mut SerialStream, out: &mut Vec<u8>, name: &str) {
    if out.is_empty() {
        return;
    }
    if let Err(e) = port.write_all(out).await {
        log::warn!("modbus_server {name}: writing to the serial line: {e}");
    }
    out.clear();
}

/// Executes one frame with a good CRC and appends the answer, if any, to `out`.
fn answer(frame: &[u8], unit: u8, shared: &Shared, out: &mut Vec<u8>) {
    let address = frame[0];
    if address != unit && address != 0 {
        return;
    }
    let pdu = &frame[1..frame.len() - 2];
    let start = out.len();
    out.push(address);
    let exception = {
        let mut image = shared.lock();
        let outcome = pdu::respond(&shared.map, &mut image, pdu, out);
        shared.outcome(&mut image, pdu, outcome)
    };
    shared.requests.fetch_add(1, Ordering::Relaxed);
    if exception {
        shared.exceptions.fetch_add(1, Ordering::Relaxed);
    }
    if address == 0 {
        out.truncate(start);
        return;
    }
    let crc = crc16(&out[start..]);
    out.extend_from_slice(&crc.to_le_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_of_the_specification_example() {
        // Read holding registers, slave 1, address 0, 1 register: 01 03 00 00 00 01 84 0A.
        let frame = [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A];
        assert_eq!(crc16(&frame[..6]), 0x0A84);
        assert!(crc_ok(&frame));
        let mut bad = frame;
        bad[3] ^= 1;
        assert!(!crc_ok(&bad));
        assert!(!crc_ok(&frame[..3]));
    }

    #[test]
    fn request_lengths() {
        assert_eq!(expect(&[1]), Expect::More);
        assert_eq!(expect(&[1, 3]), Expect::Len(8));
        assert_eq!(expect(&[1, 0x10, 0, 0, 0, 2]), Expect::More);
        assert_eq!(expect(&[1, 0x10, 0, 0, 0, 2, 4]), Expect::Len(13));
        assert_eq!(expect(&[1, 0x0F, 0, 0, 0, 10, 2]), Expect::Len(11));
        assert_eq!(
            expect(&[1, 0x17, 0, 0, 0, 1, 0, 0, 0, 1, 2]),
            Expect::Len(15)
        );
        assert_eq!(expect(&[1, 0x2B]), Expect::Silence);
    }
}
