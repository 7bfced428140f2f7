//! modbus_server over Modbus RTU on a serial line made of pseudo-terminals: tokio-modbus's RTU
//! client reads and writes every table; hand-made frames check slave addressing, broadcasts,
//! CRC errors, noise and unknown functions (answered once the line goes quiet).

mod server_support;

use std::io::{Read, Write};
use std::os::fd::AsFd;
use std::time::{Duration, Instant};

use petriplc_config::PointValue;
use petriplc_modbus::server::crc16;
use server_support::{runtime, serial_line, Line, Server, PATIENCE};
use tokio_modbus::prelude::*;

fn conf(line: &Line) -> String {
    format!(
        "\
[PLC]
module mb modbus_server
module probe probe
point C0 \"coil\" mb
point D0 \"input bit\" probe
point H16 \"holding\" mb u16
point Hf \"float\" mb f32
point Hro \"read-only\" probe u16
point I32 \"input\" probe i32
[mb]
listen = off
serial = {}:19200:8E1
unit = 5
coil 0 C0
discrete_input 0 D0
holding 0 H16
holding 1 Hf f32 low_first
holding 3 Hro
input 0 I32
[probe]
set D0 1
set Hro 77
set I32 -70000
",
        line.server.display()
    )
}

async fn timed<T>(f: impl std::future::Future<Output = T>) -> T {
    tokio::time::timeout(PATIENCE, f)
        .await
        .expect("an answer on the serial line")
}

#[test]
fn tokio_modbus_rtu_client_reads_and_writes_every_table() {
    let line = serial_line();
    let mut srv = Server::start(&conf(&line));
    assert!(
        srv.status()
            .starts_with(&format!("rtu {}:19200:8E1 unit 5", line.server.display())),
        "{}",
        srv.status()
    );
    let rt = runtime();
    let mut c = rt.block_on(async {
        let port = tokio_serial::SerialStream::open(&tokio_serial::new(
            line.client.to_string_lossy(),
            19200,
        ))
        .unwrap();
        rtu::attach_slave(port, Slave(5))
    });
    rt.block_on(async {
        assert_eq!(timed(c.read_coils(0, 1)).await.unwrap().unwrap(), [false]);
        assert_eq!(
            timed(c.read_discrete_inputs(0, 1)).await.unwrap().unwrap(),
            [true]
        );
        assert_eq!(
            timed(c.read_holding_registers(3, 1))
                .await
                .unwrap()
                .unwrap(),
            [77]
        );
        // -70000 = 0xFFFEEE90, high word first (the default).
        assert_eq!(
            timed(c.read_input_registers(0, 2)).await.unwrap().unwrap(),
            [0xFFFE, 0xEE90]
        );
        timed(c.write_single_coil(0, true)).await.unwrap().unwrap();
        timed(c.write_single_register(0, 500))
            .await
            .unwrap()
            .unwrap();
        timed(c.write_multiple_registers(1, &[0, 0x4020]))
            .await
            .unwrap()
            .unwrap();
        timed(c.write_multiple_coils(0, &[true]))
            .await
            .unwrap()
            .unwrap();
        let read = timed(c.read_write_multiple_registers(0, 4, 0, &[501]))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(read, [501, 0, 0x4020, 77]);
        assert_eq!(
            timed(c.write_single_register(3, 1))
                .await
                .unwrap()
                .unwrap_err(),
            ExceptionCode::IllegalDataAddress
        );
        assert_eq!(
            timed(c.read_holding_registers(0, 200))
                .await
                .unwrap()
                .unwrap_err(),
            ExceptionCode::IllegalDataValue
        );
    });
    srv.tick();
    assert_eq!(srv.plc.get("C0"), PointValue::Unsigned(1));
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(501));
    assert_eq!(srv.plc.get("Hf"), PointValue::Float(2.5));
}

/// The client end of the line, for hand-made frames.
struct Port {
    file: std::fs::File,
}

impl Port {
    fn open(line: &Line) -> Port {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&line.client)
            .unwrap();
        Port { file }
    }

    fn send(&mut self, frame: &[u8]) {
        self.file.write_all(frame).unwrap();
    }

    /// Sends `body` (address, function, data) with its CRC.
    fn send_frame(&mut self, body: &[u8]) {
        let mut f = body.to_vec();
        f.extend_from_slice(&crc16(body).to_le_bytes());
        self.send(&f);
    }

    /// Whatever arrives until `n` bytes are in, or `wait` has passed.
    fn receive(&mut self, n: usize, wait: Duration) -> Vec<u8> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        let deadline = Instant::now() + wait;
        let mut got = Vec::new();
        while got.len() < n {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            let ms = PollTimeout::try_from(left.as_millis().min(10_000) as i32 + 1).unwrap();
            let mut fds = [PollFd::new(self.file.as_fd(), PollFlags::POLLIN)];
            if poll(&mut fds, ms).unwrap() == 0 {
                continue;
            }
            let mut buf = [0u8; 300];
            let k = self.file.read(&mut buf).unwrap();
            got.extend_from_slice(&buf[..k]);
        }
        got
    }

    /// The answer to `body`: address, function, data (CRC checked and removed).
    fn request(&mut self, body: &[u8], answer_len: usize) -> Vec<u8> {
        self.send_frame(body);
        let got = self.receive(answer_len, PATIENCE);
        assert_eq!(got.len(), answer_len, "answer to {body:?}: {got:?}");
        assert!(petriplc_modbus::server::crc_ok(&got), "{got:?}");
        got[..got.len() - 2].to_vec()
    }
}

#[test]
fn addressing_broadcasts_noise_and_exceptions() {
    let line = serial_line();
    let mut srv = Server::start(&conf(&line));
    let mut port = Port::open(&line);
    assert_eq!(port.request(&[5, 0x03, 0, 3, 0, 1], 7), [5, 0x03, 2, 0, 77]);
    // Another slave's request and a broadcast read get no answer; the next request does.
    port.send_frame(&[6, 0x03, 0, 3, 0, 1]);
    port.send_frame(&[0, 0x03, 0, 3, 0, 1]);
    assert_eq!(
        port.receive(1, Duration::from_millis(200)),
        Vec::<u8>::new()
    );
    assert_eq!(port.request(&[5, 0x03, 0, 3, 0, 1], 7), [5, 0x03, 2, 0, 77]);
    // A broadcast write is executed, without an answer.
    port.send_frame(&[0, 0x06, 0, 0, 0x01, 0x02]);
    assert_eq!(port.request(&[5, 0x03, 0, 0, 0, 1], 7), [5, 0x03, 2, 1, 2]);
    // A bad CRC is dropped once the line is quiet; the next frame is answered.
    port.send(&[5, 0x03, 0, 3, 0, 1, 0xDE, 0xAD]);
    assert_eq!(
        port.receive(1, Duration::from_millis(200)),
        Vec::<u8>::new()
    );
    assert_eq!(port.request(&[5, 0x03, 0, 3, 0, 1], 7), [5, 0x03, 2, 0, 77]);
    // Noise, then silence, then a request.
    port.send(&[0xFF; 40]);
    port.send(b"hello, slave");
    assert_eq!(
        port.receive(1, Duration::from_millis(200)),
        Vec::<u8>::new()
    );
    assert_eq!(port.request(&[5, 0x03, 0, 3, 0, 1], 7), [5, 0x03, 2, 0, 77]);
    // An unknown function (its length unknown) is answered once the line goes quiet.
    assert_eq!(port.request(&[5, 0x41, 1, 2, 3], 5), [5, 0xC1, 0x01]);
    // A frame too short for its function, but with a good CRC: 03.
    assert_eq!(port.request(&[5, 0x03, 0, 3], 5), [5, 0x83, 0x03]);
    // Two requests back to back are both answered.
    let mut two = Vec::new();
    for body in [[5u8, 0x03, 0, 3, 0, 1], [5, 0x04, 0, 0, 0, 2]] {
        two.extend_from_slice(&body);
        two.extend_from_slice(&crc16(&body).to_le_bytes());
    }
    port.send(&two);
    let got = port.receive(7 + 9, PATIENCE);
    assert_eq!(&got[..5], [5, 0x03, 2, 0, 77]);
    assert_eq!(&got[7..14], [5, 0x04, 4, 0xFF, 0xFE, 0xEE, 0x90]);
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(0x0102));
    let (_, requests, exceptions) = srv.counts();
    assert_eq!((requests, exceptions), (11, 2), "{}", srv.status());
}

#[test]
fn tcp_and_rtu_together_share_one_image() {
    let line = serial_line();
    let text = conf(&line).replace("listen = off", "listen = 127.0.0.1:0");
    let mut srv = Server::start(&text);
    let mut port = Port::open(&line);
    let mut tcp = srv.raw();
    assert_eq!(tcp.request(1, &[0x06, 0, 0, 0, 9]), [0x06, 0, 0, 0, 9]);
    assert_eq!(port.request(&[5, 0x03, 0, 0, 0, 1], 7), [5, 0x03, 2, 0, 9]);
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(9));
}
