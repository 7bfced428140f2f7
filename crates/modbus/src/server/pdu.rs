//! The Modbus application protocol on the server side: one request PDU in, one response PDU
//! (or exception) out, against the address map and the register image. Shared by TCP and RTU.
//!
//! Checks follow the order of the specification's state diagrams (Modbus Application
//! Protocol V1.1b3, section 6): function code (01), then quantity, byte count and length
//! (03), then addresses (02), then values (03); nothing is written unless the whole request
//! is valid.

use crate::value;

use super::map::{AddressMap, Image, Table};

pub const ILLEGAL_FUNCTION: u8 = 0x01;
pub const ILLEGAL_DATA_ADDRESS: u8 = 0x02;
pub const ILLEGAL_DATA_VALUE: u8 = 0x03;

/// The specification's limits on quantities.
pub const MAX_READ_BITS: u16 = 2000;
pub const MAX_WRITE_BITS: u16 = 1968;
pub const MAX_READ_REGISTERS: u16 = 125;
pub const MAX_WRITE_REGISTERS: u16 = 123;
pub const MAX_RW_WRITE_REGISTERS: u16 = 121;

/// Appends the response to `pdu` (function code first) to `out`; returns whether it is an
/// exception response. An empty PDU gets exception 01 for function code 0.
pub fn respond(map: &AddressMap, image: &mut Image, pdu: &[u8], out: &mut Vec<u8>) -> bool {
    let (fc, body) = match pdu.split_first() {
        Some((&fc, body)) => (fc, body),
        None => (0, pdu),
    };
    let start = out.len();
    match handle(map, image, fc, body, out) {
        Ok(()) => false,
        Err(code) => {
            out.truncate(start);
            out.push(fc | 0x80);
            out.push(code);
            true
        }
    }
}

fn be(b: &[u8], i: usize) -> u16 {
    u16::from_be_bytes([b[i], b[i + 1]])
}

/// The two 16-bit fields of the fixed-size requests (01-06).
fn two_fields(body: &[u8]) -> Result<(u16, u16), u8> {
    if body.len() != 4 {
        return Err(ILLEGAL_DATA_VALUE);
    }
    Ok((be(body, 0), be(body, 2)))
}

fn quantity(q: u16, max: u16) -> Result<u16, u8> {
    if q == 0 || q > max {
        Err(ILLEGAL_DATA_VALUE)
    } else {
        Ok(q)
    }
}

fn handle(
    map: &AddressMap,
    image: &mut Image,
    fc: u8,
    body: &[u8],
    out: &mut Vec<u8>,
) -> Result<(), u8> {
    match fc {
        0x01 | 0x02 => {
            let table = if fc == 0x01 {
                Table::Coil
            } else {
                Table::DiscreteInput
            };
            let (address, q) = two_fields(body)?;
            let q = quantity(q, MAX_READ_BITS)?;
            let pos = map
                .table(table)
                .readable(address, q)
                .ok_or(ILLEGAL_DATA_ADDRESS)?;
            let bits = &image.table(table)[pos..pos + usize::from(q)];
            out.push(fc);
            out.push(bits.len().div_ceil(8) as u8);
            for chunk in bits.chunks(8) {
                let byte = chunk
                    .iter()
                    .enumerate()
                    .fold(0u8, |b, (i, &v)| b | (u8::from(v != 0) << i));
                out.push(byte);
            }
            Ok(())
        }
        0x03 | 0x04 => {
            let table = if fc == 0x03 {
                Table::Holding
            } else {
                Table::Input
            };
            let (address, q) = two_fields(body)?;
            let q = quantity(q, MAX_READ_REGISTERS)?;
            let pos = map
                .table(table)
                .readable(address, q)
                .ok_or(ILLEGAL_DATA_ADDRESS)?;
            out.push(fc);
            read_registers(image.table(table), pos, q, out);
            Ok(())
        }
        0x05 => {
            let (address, v) = two_fields(body)?;
            let on = match v {
                0xFF00 => true,
                0x0000 => false,
                _ => return Err(ILLEGAL_DATA_VALUE),
            };
            let t = map.table(Table::Coil);
            let pos = t.writable(address, 1).ok_or(ILLEGAL_DATA_ADDRESS)?;
            write_bit(map, image, pos, on)?;
            out.push(fc);
            out.extend_from_slice(body);
            Ok(())
        }
        0x06 => {
            let (address, _) = two_fields(body)?;
            write_registers(map, image, address, 1, &body[2..4])?;
            out.push(fc);
            out.extend_from_slice(body);
            Ok(())
        }
        0x0F => {
            if body.len() < 5 {
                return Err(ILLEGAL_DATA_VALUE);
            }
            let (address, q, count) = (be(body, 0), be(body, 2), body[4]);
            let q = quantity(q, MAX_WRITE_BITS)?;
            let data = &body[5..];
            if usize::from(count) != usize::from(q).div_ceil(8) || data.len() != usize::from(count)
            {
                return Err(ILLEGAL_DATA_VALUE);
            }
            let t = map.table(Table::Coil);
            let pos = t.writable(address, q).ok_or(ILLEGAL_DATA_ADDRESS)?;
            for i in 0..usize::from(q) {
                let on = data[i / 8] & (1 << (i % 8)) != 0;
                write_bit(map, image, pos + i, on)?;
            }
            out.push(fc);
            out.extend_from_slice(&body[..4]);
            Ok(())
        }
        0x10 => {
            if body.len() < 5 {
                return Err(ILLEGAL_DATA_VALUE);
            }
            let (address, q, count) = (be(body, 0), be(body, 2), body[4]);
            let q = quantity(q, MAX_WRITE_REGISTERS)?;
            let data = &body[5..];
            if usize::from(count) != 2 * usize::from(q) || data.len() != usize::from(count) {
                return Err(ILLEGAL_DATA_VALUE);
            }
            write_registers(map, image, address, q, data)?;
            out.push(fc);
            out.extend_from_slice(&body[..4]);
            Ok(())
        }
        0x17 => {
            if body.len() < 9 {
                return Err(ILLEGAL_DATA_VALUE);
            }
            let (read_address, rq) = (be(body, 0), be(body, 2));
            let (write_address, wq, count) = (be(body, 4), be(body, 6), body[8]);
            let rq = quantity(rq, MAX_READ_REGISTERS)?;
            let wq = quantity(wq, MAX_RW_WRITE_REGISTERS)?;
            let data = &body[9..];
            if usize::from(count) != 2 * usize::from(wq) || data.len() != usize::from(count) {
                return Err(ILLEGAL_DATA_VALUE);
            }
            let holding = map.table(Table::Holding);
            let pos = holding
                .readable(read_address, rq)
                .ok_or(ILLEGAL_DATA_ADDRESS)?;
            // The write comes first, as the specification says: the read sees it.
            write_registers(map, image, write_address, wq, data)?;
            out.push(fc);
            read_registers(image.table(Table::Holding), pos, rq, out);
            Ok(())
        }
        _ => Err(ILLEGAL_FUNCTION),
    }
}

/// Why a request got exception `code`, in words for the log: which address of which table,
/// and what to do about it. Only called for refused requests, off the served path.
pub fn explain(map: &AddressMap, pdu: &[u8], code: u8) -> String {
    let (fc, body) = match pdu.split_first() {
        Some((&fc, body)) => (fc, body),
        None => return "an empty request".to_string(),
    };
    if code == ILLEGAL_FUNCTION {
        return format!("function code {fc} is not served (1-6, 15, 16 and 23 are): exception 01");
    }
    let field = |i: usize| (body.len() >= i + 2).then(|| be(body, i));
    // (what the request does, table, first address, quantity)
    let (what, table, address, q) = match fc {
        0x01..=0x04 => {
            let table = match fc {
                0x01 => Table::Coil,
                0x02 => Table::DiscreteInput,
                0x03 => Table::Holding,
                _ => Table::Input,
            };
            ("read", table, field(0), field(2))
        }
        0x05 => ("write", Table::Coil, field(0), Some(1)),
        0x06 => ("write", Table::Holding, field(0), Some(1)),
        0x0F => ("write", Table::Coil, field(0), field(2)),
        0x10 => ("write", Table::Holding, field(0), field(2)),
        _ => ("write", Table::Holding, field(4), field(6)),
    };
    let (Some(address), Some(q)) = (address, q) else {
        return format!(
            "a malformed request (function {fc}, {} bytes): exception 03",
            pdu.len()
        );
    };
    let table_name = table.name();
    let range = if q == 1 {
        format!("{table_name} {address}")
    } else {
        format!(
            "{table_name} {address}-{}",
            u32::from(address) + u32::from(q) - 1
        )
    };
    if code == ILLEGAL_DATA_VALUE {
        return format!(
            "{what} {range}: exception 03, a quantity out of the protocol's limits, a byte \
             count that does not match, or a value its point cannot hold"
        );
    }
    let t = map.table(table);
    for a in u32::from(address)..u32::from(address) + u32::from(q) {
        let entry = u16::try_from(a)
            .ok()
            .and_then(|a| t.position(a))
            .and_then(|pos| t.entry_at(pos))
            .map(|e| &map.entries[e as usize]);
        match entry {
            None => {
                return format!(
                    "{what} {range}: exception 02, no point is mapped at {table_name} {a}; \
                     the server's section maps the addresses it serves"
                )
            }
            Some(e) if what == "write" && !e.writable => {
                let point = &map.points[e.point as usize].name;
                return format!(
                    "{what} {range}: exception 02, {table_name} {a} shows point `{point}`, \
                     which another module owns: clients may read it, only points the server \
                     owns can be written"
                );
            }
            Some(_) => {}
        }
    }
    format!("{what} {range}: exception 02, the range cuts a 32-bit value in two")
}

fn read_registers(values: &[u16], pos: usize, q: u16, out: &mut Vec<u8>) {
    let words = &values[pos..pos + usize::from(q)];
    out.push((2 * words.len()) as u8);
    out.reserve(2 * words.len());
    for w in words {
        out.extend_from_slice(&w.to_be_bytes());
    }
}

fn write_bit(map: &AddressMap, image: &mut Image, pos: usize, on: bool) -> Result<(), u8> {
    let e = map
        .table(Table::Coil)
        .entry_at(pos)
        .ok_or(ILLEGAL_DATA_ADDRESS)?;
    let p = map.entries[e as usize].point;
    let kind = map.points[p as usize].kind;
    image.write(map, p, value::from_bit(on, kind));
    Ok(())
}

/// Writes `q` holding registers from `address` (`data`: 2 × q bytes): every address must be
/// writable and every 32-bit value written whole (02), every value must fit its point (03).
fn write_registers(
    map: &AddressMap,
    image: &mut Image,
    address: u16,
    q: u16,
    data: &[u8],
) -> Result<(), u8> {
    let t = map.table(Table::Holding);
    let pos = t.writable(address, q).ok_or(ILLEGAL_DATA_ADDRESS)?;
    let end = u32::from(address) + u32::from(q);
    // The range is mapped without holes, so only its two ends can cut a 32-bit value.
    let first = t.entry_at(pos).ok_or(ILLEGAL_DATA_ADDRESS)?;
    let last = t
        .entry_at(pos + usize::from(q) - 1)
        .ok_or(ILLEGAL_DATA_ADDRESS)?;
    let (first, last) = (&map.entries[first as usize], &map.entries[last as usize]);
    if first.address != address || u32::from(last.address) + u32::from(last.width) != end {
        return Err(ILLEGAL_DATA_ADDRESS);
    }
    for apply in [false, true] {
        let mut i = 0usize;
        while i < usize::from(q) {
            let e = t.entry_at(pos + i).ok_or(ILLEGAL_DATA_ADDRESS)?;
            let e = &map.entries[e as usize];
            let n = usize::from(e.width);
            let mut words = [0u16; 2];
            for (k, w) in words.iter_mut().enumerate().take(n) {
                *w = be(data, 2 * (i + k));
            }
            let p = &map.points[e.point as usize];
            let v = value::convert(value::decode(&words[..n], e.ty, e.order), p.kind, p.bits)
                .ok_or(ILLEGAL_DATA_VALUE)?;
            if apply {
                image.write(map, e.point, v);
            }
            i += n;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_functions_get_01_with_the_code_echoed() {
        let map = AddressMap::default();
        let mut image = Image::new(&map);
        for fc in [0x00u8, 0x07, 0x08, 0x2B, 0x7F, 0x81, 0xFF] {
            let mut out = Vec::new();
            assert!(respond(&map, &mut image, &[fc, 1, 2], &mut out));
            assert_eq!(out, [fc | 0x80, ILLEGAL_FUNCTION]);
        }
        let mut out = Vec::new();
        assert!(respond(&map, &mut image, &[], &mut out));
        assert_eq!(out, [0x80, ILLEGAL_FUNCTION]);
    }

    #[test]
    fn short_or_long_pdus_get_03() {
        let map = AddressMap::default();
        let mut image = Image::new(&map);
        for pdu in [
            &[0x03u8, 0, 0, 0][..],
            &[0x03, 0, 0, 0, 1, 9],
            &[0x05, 0, 0],
            &[0x10, 0, 0, 0, 1],
            &[0x10, 0, 0, 0, 1, 2, 0],
            &[0x0F, 0, 0, 0, 9, 1, 0],
            &[0x17, 0, 0, 0, 1, 0, 0, 0, 1],
        ] {
            let mut out = Vec::new();
            assert!(respond(&map, &mut image, pdu, &mut out));
            assert_eq!(out, [pdu[0] | 0x80, ILLEGAL_DATA_VALUE], "{pdu:?}");
        }
    }

    #[test]
    fn quantities_are_checked_before_addresses() {
        let map = AddressMap::default();
        let mut image = Image::new(&map);
        for (pdu, code) in [
            (&[0x01u8, 0, 0, 0x07, 0xD1][..], ILLEGAL_DATA_VALUE),
            (&[0x01, 0, 0, 0x07, 0xD0], ILLEGAL_DATA_ADDRESS),
            (&[0x03, 0, 0, 0, 0], ILLEGAL_DATA_VALUE),
            (&[0x04, 0, 0, 0, 126], ILLEGAL_DATA_VALUE),
            (&[0x04, 0, 0, 0, 125], ILLEGAL_DATA_ADDRESS),
            (&[0x05, 0, 0, 0x12, 0x34], ILLEGAL_DATA_VALUE),
            (&[0x05, 0, 0, 0xFF, 0], ILLEGAL_DATA_ADDRESS),
        ] {
            let mut out = Vec::new();
            assert!(respond(&map, &mut image, pdu, &mut out));
            assert_eq!(out, [pdu[0] | 0x80, code], "{pdu:?}");
        }
    }

    /// `explain` of the exception `pdu` gets from a server mapping coil 0 to its own point
    /// `stop`, coil 1 to `lamp` (owned by another module) and holding 0 to `level`.
    fn check_explain(pdu: &[u8], expect: &str) {
        let text = "[PLC]\nmodule mb modbus_server\nmodule other timeline\n\
                    point stop \"\" mb\npoint lamp \"\" other\npoint level \"\" mb u8\n\
                    [mb]\ncoil 0 stop\ncoil 1 lamp\nholding 0 level\n";
        let config = petriplc_config::parse_str(text, "t.conf", std::path::Path::new(".")).unwrap();
        let layout = petriplc_runtime::image::Layout::new(&config).unwrap();
        let points = petriplc_runtime::image::ModuleMap::new(
            &layout,
            "mb",
            petriplc_config::Location::Local,
        )
        .unwrap();
        let rows = petriplc_modules::common::module_rows(&config, "mb");
        let map = AddressMap::build(&rows, &points, crate::value::WordOrder::HighFirst).unwrap();
        let mut image = Image::new(&map);
        let mut out = Vec::new();
        assert!(
            respond(&map, &mut image, pdu, &mut out),
            "{pdu:?} was served"
        );
        assert_eq!(explain(&map, pdu, out[1]), expect, "{pdu:?}");
    }

    #[test]
    fn refusals_are_explained() {
        check_explain(
            &[0x05, 0, 1, 0xFF, 0],
            "write coil 1: exception 02, coil 1 shows point `lamp`, which another module owns: \
             clients may read it, only points the server owns can be written",
        );
        check_explain(
            &[0x0F, 0, 0, 0, 3, 1, 7],
            "write coil 0-2: exception 02, coil 1 shows point `lamp`, which another module \
             owns: clients may read it, only points the server owns can be written",
        );
        check_explain(
            &[0x03, 0, 5, 0, 1],
            "read holding 5: exception 02, no point is mapped at holding 5; the server's \
             section maps the addresses it serves",
        );
        check_explain(
            &[0x06, 0, 0, 1, 0],
            "write holding 0: exception 03, a quantity out of the protocol's limits, a byte \
             count that does not match, or a value its point cannot hold",
        );
        check_explain(
            &[0x2B, 0x0E],
            "function code 43 is not served (1-6, 15, 16 and 23 are): exception 01",
        );
        check_explain(
            &[0x03, 0],
            "a malformed request (function 3, 2 bytes): exception 03",
        );
    }
}
