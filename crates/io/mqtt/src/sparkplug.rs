//! Sparkplug B (Eclipse Sparkplug 3.0) for the `mqtt` module: the published points become
//! the metrics of an edge node `GROUP/EDGE_NODE`: NBIRTH with every metric (name, alias,
//! datatype, value), NDATA with the changed ones by alias and a sequence number 0–255, NDEATH
//! as the MQTT will (and sent before a clean disconnect) with the bdSeq of its NBIRTH, and a
//! new NBIRTH when a host asks for it with the NCMD metric `Node Control/Rebirth`.
//!
//! The payload is the protobuf message `org.eclipse.tahu.protobuf.Payload` of the Eclipse Tahu
//! `sparkplug_b.proto`. The structs below are what `prost-build` makes of the part of that
//! schema this module writes and reads (Payload and Metric with the scalar values; the
//! dataset, template, property-set and metadata fields are skipped as unknown fields on
//! decoding, as protobuf requires): written by hand with prost's derive macros rather than
//! generated, so the build needs neither `protoc` nor a `.proto` compiler crate. The field
//! numbers are the schema's; `tests/sparkplug.rs` decodes every payload with a third-party
//! implementation (Python's pysparkplug on Google's protobuf runtime, pinned in
//! scripts/test-all.sh) to hold them to it.

use petriplc_config::{PointKind, PointValue};

/// The topic namespace of Sparkplug B.
pub const NAMESPACE: &str = "spBv1.0";
/// The node-control metric a host sets to true to ask for a new NBIRTH.
pub const REBIRTH: &str = "Node Control/Rebirth";
/// The birth/death sequence metric of NBIRTH and NDEATH.
pub const BD_SEQ: &str = "bdSeq";
/// The alias of [`REBIRTH`]; the published points take 1, 2, … in their row order.
pub const REBIRTH_ALIAS: u64 = 0;

/// `Payload` of sparkplug_b.proto (proto2).
#[derive(Clone, PartialEq, prost::Message)]
pub struct Payload {
    /// Milliseconds since 1970-01-01 UTC when the message was sent.
    #[prost(uint64, optional, tag = "1")]
    pub timestamp: Option<u64>,
    #[prost(message, repeated, tag = "2")]
    pub metrics: Vec<Metric>,
    /// 0–255: 0 in NBIRTH, one more in each later NDATA (none in NDEATH).
    #[prost(uint64, optional, tag = "3")]
    pub seq: Option<u64>,
    #[prost(string, optional, tag = "4")]
    pub uuid: Option<String>,
    #[prost(bytes = "vec", optional, tag = "5")]
    pub body: Option<Vec<u8>>,
}

/// `Payload.Metric` of sparkplug_b.proto, without metadata, properties, datasets and
/// templates.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Metric {
    #[prost(string, optional, tag = "1")]
    pub name: Option<String>,
    #[prost(uint64, optional, tag = "2")]
    pub alias: Option<u64>,
    #[prost(uint64, optional, tag = "3")]
    pub timestamp: Option<u64>,
    #[prost(uint32, optional, tag = "4")]
    pub datatype: Option<u32>,
    #[prost(bool, optional, tag = "5")]
    pub is_historical: Option<bool>,
    #[prost(bool, optional, tag = "6")]
    pub is_transient: Option<bool>,
    #[prost(bool, optional, tag = "7")]
    pub is_null: Option<bool>,
    #[prost(oneof = "Value", tags = "10, 11, 12, 13, 14, 15, 16")]
    pub value: Option<Value>,
}

/// The scalar members of `Metric.value`.
#[derive(Clone, PartialEq, prost::Oneof)]
pub enum Value {
    #[prost(uint32, tag = "10")]
    IntValue(u32),
    #[prost(uint64, tag = "11")]
    LongValue(u64),
    #[prost(float, tag = "12")]
    FloatValue(f32),
    #[prost(double, tag = "13")]
    DoubleValue(f64),
    #[prost(bool, tag = "14")]
    BooleanValue(bool),
    #[prost(string, tag = "15")]
    StringValue(String),
    #[prost(bytes = "vec", tag = "16")]
    BytesValue(Vec<u8>),
}

/// Sparkplug B data types (the numbers of the specification's DataType enumeration).
pub mod datatype {
    pub const INT8: u32 = 1;
    pub const INT16: u32 = 2;
    pub const INT32: u32 = 3;
    pub const UINT8: u32 = 5;
    pub const UINT16: u32 = 6;
    pub const UINT32: u32 = 7;
    pub const UINT64: u32 = 8;
    pub const FLOAT: u32 = 9;
    pub const BOOLEAN: u32 = 11;
}

/// The data type of a point: a 1-bit unsigned point is a Boolean, other integers the
/// smallest of 8, 16, 32 bits that holds them, floats Float.
pub fn datatype_of(kind: PointKind, bits: u8) -> u32 {
    use datatype::*;
    match (kind, bits) {
        (PointKind::Float, _) => FLOAT,
        (PointKind::Unsigned, 1) => BOOLEAN,
        (PointKind::Unsigned, 0..=8) => UINT8,
        (PointKind::Unsigned, 9..=16) => UINT16,
        (PointKind::Unsigned, _) => UINT32,
        (PointKind::Signed, 0..=8) => INT8,
        (PointKind::Signed, 9..=16) => INT16,
        (PointKind::Signed, _) => INT32,
    }
}

/// The metric value of a point value of `datatype`: integers in `int_value`, signed ones as
/// two's complement within their type's width (Int16 −12 is 65524), as the specification
/// and its implementations write them.
pub fn value_of(v: PointValue, datatype: u32) -> Value {
    match v {
        PointValue::Float(f) => Value::FloatValue(f),
        PointValue::Unsigned(u) if datatype == datatype::BOOLEAN => Value::BooleanValue(u != 0),
        PointValue::Unsigned(u) => Value::IntValue(u),
        PointValue::Signed(i) => Value::IntValue(match datatype {
            datatype::INT8 => u32::from(i as i8 as u8),
            datatype::INT16 => u32::from(i as i16 as u16),
            _ => i as u32,
        }),
    }
}

/// The edge node's identity and the topics it uses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Node {
    pub group: String,
    pub node: String,
}

impl Node {
    /// `GROUP/EDGE_NODE`: two non-empty names without `/`, `+` or `#`.
    pub fn parse(text: &str) -> Result<Node, String> {
        let fix = || {
            format!(
                "`sparkplug = {text}`: write GROUP/EDGE_NODE (the Sparkplug group id and edge \
                 node id, e.g. `sparkplug = plant/cell-a`), each without `/`, `+` or `#`"
            )
        };
        let (group, node) = text.split_once('/').ok_or_else(fix)?;
        let ok = |s: &str| !s.is_empty() && !s.contains(['/', '+', '#', '\0']);
        if !ok(group) || !ok(node) {
            return Err(fix());
        }
        Ok(Node {
            group: group.to_string(),
            node: node.to_string(),
        })
    }

    /// `spBv1.0/GROUP/KIND/EDGE_NODE` for KIND NBIRTH, NDATA, NDEATH, NCMD.
    pub fn topic(&self, kind: &str) -> String {
        format!("{NAMESPACE}/{}/{kind}/{}", self.group, self.node)
    }
}

/// A published point as a metric.
#[derive(Clone, Debug)]
pub struct MetricDef {
    pub name: String,
    pub alias: u64,
    pub datatype: u32,
}

fn bd_seq_metric(bd_seq: u64, ts: u64) -> Metric {
    Metric {
        name: Some(BD_SEQ.to_string()),
        timestamp: Some(ts),
        datatype: Some(datatype::UINT64),
        value: Some(Value::LongValue(bd_seq)),
        ..Metric::default()
    }
}

/// The NDEATH payload (the MQTT will): the timestamp and the bdSeq metric, no seq.
pub fn death(bd_seq: u64, ts: u64) -> Vec<u8> {
    prost::Message::encode_to_vec(&Payload {
        timestamp: Some(ts),
        metrics: vec![bd_seq_metric(bd_seq, ts)],
        ..Payload::default()
    })
}

/// The NBIRTH payload: seq 0, bdSeq, `Node Control/Rebirth` (false) and every point with its
/// name, alias, datatype and value.
pub fn birth(bd_seq: u64, ts: u64, defs: &[MetricDef], values: &[PointValue]) -> Vec<u8> {
    let mut metrics = Vec::with_capacity(defs.len() + 2);
    metrics.push(bd_seq_metric(bd_seq, ts));
    metrics.push(Metric {
        name: Some(REBIRTH.to_string()),
        alias: Some(REBIRTH_ALIAS),
        timestamp: Some(ts),
        datatype: Some(datatype::BOOLEAN),
        value: Some(Value::BooleanValue(false)),
        ..Metric::default()
    });
    for (d, &v) in defs.iter().zip(values) {
        metrics.push(Metric {
            name: Some(d.name.clone()),
            alias: Some(d.alias),
            timestamp: Some(ts),
            datatype: Some(d.datatype),
            value: Some(value_of(v, d.datatype)),
            ..Metric::default()
        });
    }
    prost::Message::encode_to_vec(&Payload {
        timestamp: Some(ts),
        metrics,
        seq: Some(0),
        ..Payload::default()
    })
}

/// An NDATA payload: the changed metrics by alias (with their datatype, which the
/// specification allows and which lets a host that missed the NBIRTH decode them), each with
/// the time of the scan that saw the change.
pub fn data(seq: u8, ts: u64, changes: &[(&MetricDef, PointValue, u64)]) -> Vec<u8> {
    prost::Message::encode_to_vec(&Payload {
        timestamp: Some(ts),
        metrics: changes
            .iter()
            .map(|&(d, v, at)| Metric {
                alias: Some(d.alias),
                timestamp: Some(at),
                datatype: Some(d.datatype),
                value: Some(value_of(v, d.datatype)),
                ..Metric::default()
            })
            .collect(),
        seq: Some(u64::from(seq)),
        ..Payload::default()
    })
}

/// Whether an NCMD payload asks for a rebirth (`Node Control/Rebirth` true, by name or by
/// its alias); other commands are not taken (the points a host may write are the module's
/// `subscribe` rows).
pub fn asks_rebirth(payload: &[u8]) -> Result<bool, String> {
    let p: Payload = prost::Message::decode(payload)
        .map_err(|e| format!("the NCMD payload is not a Sparkplug B payload: {e}"))?;
    Ok(p.metrics.iter().any(|m| {
        let named = match (&m.name, m.alias) {
            (Some(n), _) => n == REBIRTH,
            (None, Some(a)) => a == REBIRTH_ALIAS,
            (None, None) => false,
        };
        named && m.value == Some(Value::BooleanValue(true))
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use prost::Message;

    fn check(text: &str, expect: Result<(&str, &str), &str>) {
        match (Node::parse(text), expect) {
            (Ok(n), Ok((g, e))) => assert_eq!((n.group.as_str(), n.node.as_str()), (g, e)),
            (Err(e), Err(why)) => assert!(e.contains(why), "{text}: {e}"),
            (got, want) => panic!("{text}: got {got:?}, expected {want:?}"),
        }
    }

    #[test]
    fn group_and_edge_node_ids() {
        check("plant/cell-a", Ok(("plant", "cell-a")));
        check("plant", Err("write GROUP/EDGE_NODE"));
        check("plant/a/b", Err("write GROUP/EDGE_NODE"));
        check("/a", Err("write GROUP/EDGE_NODE"));
        check("p/+", Err("write GROUP/EDGE_NODE"));
        assert_eq!(
            Node::parse("g/n").unwrap().topic("NBIRTH"),
            "spBv1.0/g/NBIRTH/n"
        );
    }

    #[test]
    fn points_map_to_sparkplug_types_and_values() {
        use datatype::*;
        use PointValue as V;
        let cases = [
            (
                PointKind::Unsigned,
                1,
                V::Unsigned(1),
                BOOLEAN,
                Value::BooleanValue(true),
            ),
            (
                PointKind::Unsigned,
                8,
                V::Unsigned(200),
                UINT8,
                Value::IntValue(200),
            ),
            (
                PointKind::Unsigned,
                12,
                V::Unsigned(4000),
                UINT16,
                Value::IntValue(4000),
            ),
            (
                PointKind::Unsigned,
                32,
                V::Unsigned(u32::MAX),
                UINT32,
                Value::IntValue(u32::MAX),
            ),
            (
                PointKind::Signed,
                8,
                V::Signed(-1),
                INT8,
                Value::IntValue(255),
            ),
            (
                PointKind::Signed,
                16,
                V::Signed(-12),
                INT16,
                Value::IntValue(65524),
            ),
            (
                PointKind::Signed,
                32,
                V::Signed(-2),
                INT32,
                Value::IntValue(u32::MAX - 1),
            ),
            (
                PointKind::Float,
                32,
                V::Float(-0.5),
                FLOAT,
                Value::FloatValue(-0.5),
            ),
        ];
        for (kind, bits, v, dt, value) in cases {
            assert_eq!(datatype_of(kind, bits), dt, "{kind:?}{bits}");
            assert_eq!(value_of(v, dt), value, "{v:?}");
        }
    }

    #[test]
    fn births_data_and_deaths_read_back() {
        let defs = [MetricDef {
            name: "N1".into(),
            alias: 1,
            datatype: datatype::BOOLEAN,
        }];
        let b = Payload::decode(&birth(3, 10, &defs, &[PointValue::Unsigned(1)])[..]).unwrap();
        assert_eq!(b.seq, Some(0));
        let names: Vec<_> = b.metrics.iter().map(|m| m.name.clone().unwrap()).collect();
        assert_eq!(names, [BD_SEQ, REBIRTH, "N1"]);
        assert_eq!(b.metrics[0].value, Some(Value::LongValue(3)));
        assert_eq!(b.metrics[2].alias, Some(1));
        let d = Payload::decode(&data(7, 11, &[(&defs[0], PointValue::Unsigned(0), 9)])[..]);
        let d = d.unwrap();
        assert_eq!((d.seq, d.metrics[0].name.as_ref()), (Some(7), None));
        assert_eq!(d.metrics[0].value, Some(Value::BooleanValue(false)));
        let x = Payload::decode(&death(3, 12)[..]).unwrap();
        assert_eq!((x.seq, x.metrics.len()), (None, 1));
        assert_eq!(x.metrics[0].value, Some(Value::LongValue(3)));
    }

    #[test]
    fn rebirth_requests_are_recognised_by_name_or_alias() {
        let cmd = |m: Metric| {
            Payload {
                metrics: vec![m],
                ..Payload::default()
            }
            .encode_to_vec()
        };
        let by_name = Metric {
            name: Some(REBIRTH.into()),
            value: Some(Value::BooleanValue(true)),
            ..Metric::default()
        };
        let by_alias = Metric {
            alias: Some(REBIRTH_ALIAS),
            value: Some(Value::BooleanValue(true)),
            ..Metric::default()
        };
        let other = Metric {
            name: Some("Node Control/Reboot".into()),
            value: Some(Value::BooleanValue(true)),
            ..Metric::default()
        };
        let falsy = Metric {
            value: Some(Value::BooleanValue(false)),
            ..by_name.clone()
        };
        assert_eq!(asks_rebirth(&cmd(by_name)), Ok(true));
        assert_eq!(asks_rebirth(&cmd(by_alias)), Ok(true));
        assert_eq!(asks_rebirth(&cmd(other)), Ok(false));
        assert_eq!(asks_rebirth(&cmd(falsy)), Ok(false));
        assert!(asks_rebirth(b"\xff\xff").is_err());
    }
}
