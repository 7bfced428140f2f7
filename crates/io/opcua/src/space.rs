//! The address space and its rules: a folder per module below Objects, a typed variable per
//! point (browse and display name = the point's name, description, `Owner` property), every
//! petrinet module's marking and every module's status as read-only variables; writes only to
//! the points this module owns, by users allowed to write.

use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::Arc;

use async_trait::async_trait;
use opcua::nodes::{ObjectBuilder, VariableBuilder};
use opcua::server::address_space::{AccessLevel, AddressSpace};
use opcua::server::authenticator::{
    user_pass_security_policy_id, user_pass_security_policy_uri, AuthManager, Password, UserToken,
};
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{
    InMemoryNodeManagerImpl, InMemoryNodeManagerImplBuilder,
};
use opcua::server::node_manager::{RequestContext, ServerContext, WriteNode};
use opcua::server::ServerEndpoint;
use opcua::sync::RwLock;
use opcua::types::{
    AttributeId, DataTypeId, DataValue, DateTime, Error, NodeId, ObjectId, QualifiedName,
    StatusCode, UAString, UserTokenPolicy, UserTokenType, VariableTypeId, Variant,
};
use petriplc_config::{PointKind, PointValue};

use crate::settings::Anonymous;
use crate::users::Users;
use crate::{lock, Shared};

/// One variable of the address space.
#[derive(Clone, Debug)]
pub struct Var {
    /// The string part of its node id.
    pub id: String,
    pub name: String,
    pub description: String,
    /// The string id of the folder it sits in.
    pub parent: String,
    pub data_type: DataTypeId,
    /// Some point this module owns: its index among the points.
    pub writable: Option<usize>,
    /// The point's kind and width, for checking written values.
    pub kind: Option<(PointKind, u8)>,
    /// `Owner` property (points only).
    pub owner: Option<String>,
}

/// A folder below Objects, one per module.
#[derive(Clone, Debug)]
pub struct Folder {
    pub id: String,
    pub name: String,
    pub description: String,
    /// Sub-folders (`Status`, `Marking`): (id, name).
    pub children: Vec<(String, String)>,
}

/// What the address space holds, decided at init.
#[derive(Clone, Debug, Default)]
pub struct Layout {
    pub folders: Vec<Folder>,
    pub vars: Vec<Var>,
}

/// The OPC UA type of a point.
pub fn data_type(kind: PointKind, bits: u8) -> DataTypeId {
    match (kind, bits) {
        (PointKind::Float, _) => DataTypeId::Float,
        (PointKind::Unsigned, 1) => DataTypeId::Boolean,
        (PointKind::Unsigned, 2..=8) => DataTypeId::Byte,
        (PointKind::Unsigned, 9..=16) => DataTypeId::UInt16,
        (PointKind::Unsigned, _) => DataTypeId::UInt32,
        (PointKind::Signed, 1..=8) => DataTypeId::SByte,
        (PointKind::Signed, 9..=16) => DataTypeId::Int16,
        (PointKind::Signed, _) => DataTypeId::Int32,
    }
}

/// A point's value as the variant of its node's type.
pub fn variant(v: PointValue, ty: DataTypeId) -> Variant {
    match (v, ty) {
        (PointValue::Float(f), _) => Variant::Float(f),
        (PointValue::Unsigned(u), DataTypeId::Boolean) => Variant::Boolean(u != 0),
        (PointValue::Unsigned(u), DataTypeId::Byte) => Variant::Byte(u as u8),
        (PointValue::Unsigned(u), DataTypeId::UInt16) => Variant::UInt16(u as u16),
        (PointValue::Unsigned(u), _) => Variant::UInt32(u),
        (PointValue::Signed(i), DataTypeId::SByte) => Variant::SByte(i as i8),
        (PointValue::Signed(i), DataTypeId::Int16) => Variant::Int16(i as i16),
        (PointValue::Signed(i), _) => Variant::Int32(i),
    }
}

/// A written value for a point of `kind` and `bits`, converted exactly or refused
/// (docs/opcua.md, "Writes"): a Boolean into a 1-bit point; an integer of any width whose
/// value the point holds (into a float point: only if the f32 holds it exactly); a Float or
/// Double into a float point, rounded to the nearest f32, if finite there. NaN, ±Inf and
/// values beyond the point's range are `BadOutOfRange` (one NaN reaching an IEC program
/// would stop it); any other type, Null and arrays are `BadTypeMismatch`.
pub fn written(v: &Variant, kind: PointKind, bits: u8) -> Result<PointValue, StatusCode> {
    let int: i128 = match *v {
        Variant::Boolean(b) if kind == PointKind::Unsigned && bits == 1 => {
            return Ok(PointValue::Unsigned(u32::from(b)))
        }
        Variant::SByte(x) => x.into(),
        Variant::Byte(x) => x.into(),
        Variant::Int16(x) => x.into(),
        Variant::UInt16(x) => x.into(),
        Variant::Int32(x) => x.into(),
        Variant::UInt32(x) => x.into(),
        Variant::Int64(x) => x.into(),
        Variant::UInt64(x) => x.into(),
        Variant::Float(f) if kind == PointKind::Float => return real(f64::from(f)),
        Variant::Double(d) if kind == PointKind::Float => return real(d),
        _ => return Err(StatusCode::BadTypeMismatch),
    };
    let bits = u32::from(bits);
    let fits = match kind {
        PointKind::Float => {
            // |int| <= 2^64 here, so the f32 converts back to i128 exactly.
            let f = int as f32;
            return if f as i128 == int {
                Ok(PointValue::Float(f))
            } else {
                Err(StatusCode::BadOutOfRange)
            };
        }
        PointKind::Unsigned => (0..1i128 << bits).contains(&int),
        PointKind::Signed => (-(1i128 << (bits - 1))..1i128 << (bits - 1)).contains(&int),
    };
    match kind {
        _ if !fits => Err(StatusCode::BadOutOfRange),
        PointKind::Unsigned => Ok(PointValue::Unsigned(int as u32)),
        _ => Ok(PointValue::Signed(int as i32)),
    }
}

/// A Float or Double for a float point: rounded to the nearest f32; NaN, ±Inf and what only
/// an f32's Inf would hold refused.
fn real(d: f64) -> Result<PointValue, StatusCode> {
    let f = d as f32;
    if f.is_finite() {
        Ok(PointValue::Float(f))
    } else {
        Err(StatusCode::BadOutOfRange)
    }
}

/// Builds the node manager of petriplc's namespace.
pub struct PlcNodesBuilder {
    pub uri: String,
    pub layout: Arc<Layout>,
    pub shared: Arc<Shared>,
}

/// petriplc's node manager.
pub struct PlcNodes {
    namespace: NamespaceMetadata,
    layout: Arc<Layout>,
    shared: Arc<Shared>,
    /// Node id → index in `layout.vars`.
    index: HashMap<NodeId, usize>,
}

impl PlcNodes {
    fn node_id(&self, id: &str) -> NodeId {
        NodeId::new(self.namespace.namespace_index, id.to_string())
    }

    /// A browse name in petriplc's namespace.
    fn browse(&self, name: &str) -> QualifiedName {
        QualifiedName::new(self.namespace.namespace_index, name)
    }
}

impl InMemoryNodeManagerImplBuilder for PlcNodesBuilder {
    type Impl = PlcNodes;

    fn build(self, context: ServerContext, address_space: &mut AddressSpace) -> PlcNodes {
        let namespace_index = {
            let mut type_tree = context.type_tree.write();
            type_tree.namespaces_mut().add_namespace(&self.uri)
        };
        address_space.add_namespace(&self.uri, namespace_index);
        let index = self
            .layout
            .vars
            .iter()
            .enumerate()
            .map(|(i, v)| (NodeId::new(namespace_index, v.id.clone()), i))
            .collect();
        PlcNodes {
            namespace: NamespaceMetadata {
                namespace_uri: self.uri,
                namespace_index,
                ..Default::default()
            },
            layout: self.layout,
            shared: self.shared,
            index,
        }
    }
}

#[async_trait]
impl InMemoryNodeManagerImpl for PlcNodes {
    async fn init(&self, address_space: &mut AddressSpace, _context: ServerContext) {
        let objects: NodeId = ObjectId::ObjectsFolder.into();
        for f in &self.layout.folders {
            let id = self.node_id(&f.id);
            ObjectBuilder::new(&id, self.browse(&f.name), f.name.as_str())
                .description(f.description.as_str())
                .is_folder()
                .organized_by(objects.clone())
                .insert(address_space);
            for (sub, name) in &f.children {
                ObjectBuilder::new(&self.node_id(sub), self.browse(name), name.as_str())
                    .is_folder()
                    .organized_by(id.clone())
                    .insert(address_space);
            }
        }
        let values = lock(&self.shared.values).now.clone();
        for (v, value) in self.layout.vars.iter().zip(values) {
            let id = self.node_id(&v.id);
            let access = if v.writable.is_some() {
                AccessLevel::CURRENT_READ | AccessLevel::CURRENT_WRITE
            } else {
                AccessLevel::CURRENT_READ
            };
            VariableBuilder::new(&id, self.browse(&v.name), v.name.as_str())
                .description(v.description.as_str())
                .data_type(v.data_type)
                .value(value)
                .access_level(access)
                .user_access_level(access)
                .minimum_sampling_interval(self.shared.scan_ms)
                .has_type_definition(VariableTypeId::BaseDataVariableType)
                .organized_by(self.node_id(&v.parent))
                .insert(address_space);
            if let Some(owner) = &v.owner {
                VariableBuilder::new(
                    &self.node_id(&format!("{}.Owner", v.id)),
                    self.browse("Owner"),
                    "Owner",
                )
                .description("the module that writes this point")
                .data_type(DataTypeId::String)
                .value(owner.as_str())
                .access_level(AccessLevel::CURRENT_READ)
                .user_access_level(AccessLevel::CURRENT_READ)
                .has_type_definition(VariableTypeId::PropertyType)
                .property_of(id.clone())
                .insert(address_space);
            }
        }
        self.shared.ready.store(true, Ordering::Release);
        // Changes made while the space was being built.
        self.shared.wake.notify_one();
    }

    fn name(&self) -> &str {
        "petriplc"
    }

    fn namespaces(&self) -> Vec<NamespaceMetadata> {
        vec![self.namespace.clone()]
    }

    async fn write(
        &self,
        context: &RequestContext,
        address_space: &RwLock<AddressSpace>,
        nodes_to_write: &mut [&mut WriteNode],
    ) -> Result<(), StatusCode> {
        let mut space = address_space.write();
        let mut changed = Vec::new();
        for node in nodes_to_write.iter_mut() {
            let w = node.value();
            let Some(&i) = self.index.get(&w.node_id) else {
                let status = if space.find(&w.node_id).is_some() {
                    StatusCode::BadNotWritable
                } else {
                    StatusCode::BadNodeIdUnknown
                };
                node.set_status(status);
                continue;
            };
            let var = &self.layout.vars[i];
            let (Some(point), Some((kind, bits))) = (var.writable, var.kind) else {
                // Another module's point, a marking or a status: read-only for everyone.
                node.set_status(StatusCode::BadNotWritable);
                continue;
            };
            if w.attribute_id != AttributeId::Value {
                node.set_status(StatusCode::BadNotWritable);
                continue;
            }
            if w.index_range.has_range() {
                node.set_status(StatusCode::BadWriteNotSupported);
                continue;
            }
            let level = context.authenticator.effective_user_access_level(
                &context.token,
                AccessLevel::CURRENT_READ | AccessLevel::CURRENT_WRITE,
                &w.node_id,
            );
            if !level.contains(AccessLevel::CURRENT_WRITE) {
                node.set_status(StatusCode::BadUserAccessDenied);
                continue;
            }
            let Some(value) = &w.value.value else {
                node.set_status(StatusCode::BadTypeMismatch);
                continue;
            };
            match written(value, kind, bits) {
                Ok(pv) => {
                    lock(&self.shared.writes).push(point, pv);
                    self.shared.written.fetch_add(1, Ordering::Relaxed);
                    let shown = variant(pv, var.data_type);
                    let now = DateTime::now();
                    let dv = DataValue {
                        value: Some(shown),
                        status: Some(StatusCode::Good),
                        source_timestamp: Some(now),
                        server_timestamp: Some(now),
                        ..Default::default()
                    };
                    if let Some(opcua::nodes::NodeType::Variable(v)) = space.find_mut(&w.node_id) {
                        v.set_data_value(dv.clone());
                    }
                    changed.push((dv, w.node_id.clone()));
                    node.set_status(StatusCode::Good);
                }
                Err(e) => node.set_status(e),
            }
        }
        drop(space);
        // Shown at once to every subscriber, as the read-back is; the point itself changes at
        // the module's next scan.
        context.subscriptions.notify_data_change(
            changed
                .iter()
                .map(|(dv, id)| (dv.clone(), id, AttributeId::Value)),
        );
        Ok(())
    }
}

/// A user name a client sent, fit for one log line: control characters escaped (no forged
/// lines), at most 64 characters.
fn shown_name(name: &str) -> String {
    let mut out: String = name.chars().take(64).flat_map(char::escape_debug).collect();
    if name.chars().nth(64).is_some() {
        out.push('…');
    }
    out
}

/// Who may connect and what they may do.
pub struct Auth {
    pub anonymous: Anonymous,
    pub users: Arc<Users>,
    pub module: String,
}

const ANONYMOUS_POLICY: &str = "anonymous";

#[async_trait]
impl AuthManager for Auth {
    async fn authenticate_anonymous_token(&self, _endpoint: &ServerEndpoint) -> Result<(), Error> {
        if self.anonymous == Anonymous::No {
            return Err(Error::new(
                StatusCode::BadIdentityTokenRejected,
                "anonymous access is off",
            ));
        }
        Ok(())
    }

    async fn authenticate_username_identity_token(
        &self,
        _endpoint: &ServerEndpoint,
        username: &str,
        password: &Password,
    ) -> Result<UserToken, Error> {
        let users = Arc::clone(&self.users);
        let (name, pw) = (username.to_string(), password.get().to_string());
        // bcrypt is slow on purpose: keep it off the network threads.
        let ok = tokio::task::spawn_blocking(move || users.check(&name, &pw))
            .await
            .unwrap_or(false);
        if ok {
            Ok(UserToken(format!("user:{username}")))
        } else {
            log::warn!(
                "opcua_server {}: refused user `{}` (unknown user or wrong password)",
                self.module,
                shown_name(username)
            );
            Err(Error::new(
                StatusCode::BadUserAccessDenied,
                "unknown user or wrong password",
            ))
        }
    }

    fn effective_user_access_level(
        &self,
        token: &UserToken,
        user_access_level: AccessLevel,
        _node_id: &NodeId,
    ) -> AccessLevel {
        if token.is_anonymous() && self.anonymous != Anonymous::Write {
            user_access_level - AccessLevel::CURRENT_WRITE
        } else {
            user_access_level
        }
    }

    fn user_token_policies(&self, endpoint: &ServerEndpoint) -> Vec<UserTokenPolicy> {
        let mut policies = Vec::new();
        if self.anonymous != Anonymous::No {
            policies.push(UserTokenPolicy {
                policy_id: UAString::from(ANONYMOUS_POLICY),
                token_type: UserTokenType::Anonymous,
                issued_token_type: UAString::null(),
                issuer_endpoint_url: UAString::null(),
                security_policy_uri: UAString::null(),
            });
        }
        if !self.users.is_empty() {
            policies.push(UserTokenPolicy {
                policy_id: user_pass_security_policy_id(endpoint),
                token_type: UserTokenType::UserName,
                issued_token_type: UAString::null(),
                issuer_endpoint_url: UAString::null(),
                security_policy_uri: user_pass_security_policy_uri(endpoint),
            });
        }
        policies
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(v: Variant, kind: PointKind, bits: u8, expect: Result<PointValue, StatusCode>) {
        assert_eq!(written(&v, kind, bits), expect, "{v:?} into {kind:?}{bits}");
    }

    #[test]
    fn written_values_must_fit_their_points() {
        use PointKind::*;
        use PointValue as V;
        check(Variant::Boolean(true), Unsigned, 1, Ok(V::Unsigned(1)));
        check(Variant::Int64(1), Unsigned, 1, Ok(V::Unsigned(1)));
        check(
            Variant::Int64(2),
            Unsigned,
            1,
            Err(StatusCode::BadOutOfRange),
        );
        check(
            Variant::Boolean(true),
            Unsigned,
            8,
            Err(StatusCode::BadTypeMismatch),
        );
        check(
            Variant::UInt16(300),
            Unsigned,
            8,
            Err(StatusCode::BadOutOfRange),
        );
        check(Variant::Int16(-5), Signed, 8, Ok(V::Signed(-5)));
        check(
            Variant::Int32(-129),
            Signed,
            8,
            Err(StatusCode::BadOutOfRange),
        );
        check(
            Variant::Float(1.5),
            Unsigned,
            8,
            Err(StatusCode::BadTypeMismatch),
        );
        check(Variant::Double(1.5), Float, 32, Ok(V::Float(1.5)));
        check(
            Variant::Double(1e300),
            Float,
            32,
            Err(StatusCode::BadOutOfRange),
        );
        check(Variant::Int32(7), Float, 32, Ok(V::Float(7.0)));
        check(
            Variant::from("1"),
            Unsigned,
            1,
            Err(StatusCode::BadTypeMismatch),
        );
        check(
            Variant::UInt64(u64::MAX),
            Unsigned,
            32,
            Err(StatusCode::BadOutOfRange),
        );
    }

    /// Issue 27: one NaN written by a client stopped the whole PLC (an `iec` module reading
    /// the point faulted on `temp * 2.0`, `on_failure = stop`).
    #[test]
    fn non_finite_values_are_refused_as_out_of_range() {
        use PointKind::*;
        let nan = [
            Variant::Float(f32::NAN),
            Variant::Float(-f32::NAN),
            Variant::Float(f32::INFINITY),
            Variant::Float(f32::NEG_INFINITY),
            Variant::Double(f64::NAN),
            Variant::Double(f64::INFINITY),
            Variant::Double(f64::NEG_INFINITY),
            // Finite doubles that would be ±Inf in an f32 point.
            Variant::Double(1e39),
            Variant::Double(-1e39),
            Variant::Double(f64::MAX),
        ];
        for v in nan {
            check(v.clone(), Float, 32, Err(StatusCode::BadOutOfRange));
            // A float is never written into an integer point, whatever its value.
            check(v, Signed, 32, Err(StatusCode::BadTypeMismatch));
        }
        // The largest finite f32 and a double that rounds to it are fine.
        check(
            Variant::Float(f32::MAX),
            Float,
            32,
            Ok(PointValue::Float(f32::MAX)),
        );
        check(
            Variant::Double(f64::from(f32::MAX)),
            Float,
            32,
            Ok(PointValue::Float(f32::MAX)),
        );
    }

    /// An integer reaches a float point only if the f32 holds it exactly: 16777217 would
    /// silently become 16777216.
    #[test]
    fn integers_into_float_points_must_be_exact() {
        use PointKind::*;
        check(
            Variant::Int32(16_777_216),
            Float,
            32,
            Ok(PointValue::Float(16_777_216.0)),
        );
        check(
            Variant::Int32(-16_777_216),
            Float,
            32,
            Ok(PointValue::Float(-16_777_216.0)),
        );
        check(
            Variant::Int32(16_777_217),
            Float,
            32,
            Err(StatusCode::BadOutOfRange),
        );
        check(
            Variant::Int64(1 << 40),
            Float,
            32,
            Ok(PointValue::Float(1_099_511_627_776.0)),
        );
        check(
            Variant::Int64(i64::MAX),
            Float,
            32,
            Err(StatusCode::BadOutOfRange),
        );
        check(
            Variant::Int64(i64::MIN),
            Float,
            32,
            Ok(PointValue::Float(-9_223_372_036_854_775_808.0)),
        );
        check(
            Variant::UInt64(u64::MAX),
            Float,
            32,
            Err(StatusCode::BadOutOfRange),
        );
        check(
            Variant::UInt64(1 << 63),
            Float,
            32,
            Ok(PointValue::Float(9_223_372_036_854_775_808.0)),
        );
    }

    /// Any variant into any point: either refused with one of the two statuses a value can
    /// earn, the point untouched, or a value the point holds, finite, equal to what was
    /// sent (a float rounded to the nearest f32).
    fn any_variant() -> impl Strategy<Value = Variant> {
        prop_oneof![
            any::<bool>().prop_map(Variant::Boolean),
            any::<i8>().prop_map(Variant::SByte),
            any::<u8>().prop_map(Variant::Byte),
            any::<i16>().prop_map(Variant::Int16),
            any::<u16>().prop_map(Variant::UInt16),
            any::<i32>().prop_map(Variant::Int32),
            any::<u32>().prop_map(Variant::UInt32),
            any::<i64>().prop_map(Variant::Int64),
            any::<u64>().prop_map(Variant::UInt64),
            (-40i64..40).prop_map(Variant::Int64),
            any::<f32>().prop_map(Variant::Float),
            any::<f64>().prop_map(Variant::Double),
            proptest::num::f32::ANY.prop_map(Variant::Float),
            proptest::num::f64::ANY.prop_map(Variant::Double),
            ".{0,40}".prop_map(|s: String| Variant::from(s)),
            proptest::collection::vec(any::<i32>(), 0..4).prop_map(Variant::from),
            proptest::collection::vec(any::<f32>(), 0..4).prop_map(Variant::from),
            Just(Variant::Empty),
            Just(Variant::from(vec![1u8, 2])),
        ]
    }

    fn point() -> impl Strategy<Value = (PointKind, u8)> {
        prop_oneof![
            (1u8..=32).prop_map(|b| (PointKind::Unsigned, b)),
            (1u8..=32).prop_map(|b| (PointKind::Signed, b)),
            Just((PointKind::Float, 32)),
        ]
    }

    /// The exact number a numeric variant carries.
    fn number(v: &Variant) -> Option<f64> {
        Some(match *v {
            Variant::Boolean(b) => f64::from(u8::from(b)),
            Variant::SByte(x) => x.into(),
            Variant::Byte(x) => x.into(),
            Variant::Int16(x) => x.into(),
            Variant::UInt16(x) => x.into(),
            Variant::Int32(x) => x.into(),
            Variant::UInt32(x) => x.into(),
            Variant::Int64(x) => x as f64,
            Variant::UInt64(x) => x as f64,
            Variant::Float(f) => f64::from(f),
            Variant::Double(d) => f64::from(d as f32),
            _ => return None,
        })
    }

    proptest! {
        #[test]
        fn any_variant_is_converted_exactly_or_refused(v in any_variant(), (kind, bits) in point()) {
            match written(&v, kind, bits) {
                Err(s) => {
                    prop_assert!(
                        s == StatusCode::BadOutOfRange || s == StatusCode::BadTypeMismatch,
                        "{s}"
                    );
                    if s == StatusCode::BadOutOfRange {
                        prop_assert!(number(&v).is_some(), "{v:?}: out of range, not a number");
                    }
                }
                Ok(pv) => {
                    let n = number(&v).expect("only numbers are written");
                    let (got, lo, hi) = match pv {
                        PointValue::Unsigned(u) => {
                            (f64::from(u), 0.0, 2f64.powi(i32::from(bits)) - 1.0)
                        }
                        PointValue::Signed(i) => {
                            let half = 2f64.powi(i32::from(bits) - 1);
                            (f64::from(i), -half, half - 1.0)
                        }
                        PointValue::Float(f) => (f64::from(f), f64::from(f32::MIN), f64::from(f32::MAX)),
                    };
                    prop_assert!(got.is_finite() && (lo..=hi).contains(&got), "{v:?} -> {pv:?}");
                    // Integers keep their exact value (compared as i128, not through f64).
                    match (&v, pv) {
                        (Variant::Int64(x), PointValue::Float(f)) => prop_assert_eq!(f as i128, i128::from(*x)),
                        (Variant::UInt64(x), PointValue::Float(f)) => prop_assert_eq!(f as i128, i128::from(*x)),
                        _ => prop_assert_eq!(got, n, "{:?} -> {:?}", v, pv),
                    }
                }
            }
        }
    }

    #[test]
    fn user_names_from_clients_are_logged_on_one_short_line() {
        assert_eq!(shown_name("op"), "op");
        assert_eq!(shown_name("op\n[ERROR] forged"), "op\\n[ERROR] forged");
        assert_eq!(
            shown_name(&"x".repeat(10_000)),
            format!("{}…", "x".repeat(64))
        );
    }

    #[test]
    fn points_map_to_the_smallest_opcua_type_that_holds_them() {
        use PointKind::*;
        let cases = [
            (Unsigned, 1, DataTypeId::Boolean),
            (Unsigned, 8, DataTypeId::Byte),
            (Unsigned, 12, DataTypeId::UInt16),
            (Unsigned, 32, DataTypeId::UInt32),
            (Signed, 1, DataTypeId::SByte),
            (Signed, 16, DataTypeId::Int16),
            (Signed, 17, DataTypeId::Int32),
            (Float, 32, DataTypeId::Float),
        ];
        for (k, b, t) in cases {
            assert_eq!(data_type(k, b), t, "{k:?}{b}");
        }
        assert_eq!(
            variant(PointValue::Unsigned(1), DataTypeId::Boolean),
            Variant::Boolean(true)
        );
        assert_eq!(
            variant(PointValue::Signed(-1), DataTypeId::SByte),
            Variant::SByte(-1)
        );
    }
}
