//! The data types of IEC 61131-3 as the checker and the engine see them: elementary types
//! ([`Elem`]), bounded strings, arrays, structures, enumerations, subranges and function
//! block instances, interned in a [`TypeTable`] so that equal types have equal ids.

use std::collections::HashMap;

use crate::value::Value;

pub use petriplc_iec_syntax::ast::RefKind;

/// The elementary types. `LDATE`, `LTOD` and `LDT` are read as `DATE`, `TOD` and `DT`: all
/// of them are 64-bit nanosecond counts here.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Elem {
    Bool,
    Sint,
    Int,
    Dint,
    Lint,
    Usint,
    Uint,
    Udint,
    Ulint,
    Byte,
    Word,
    Dword,
    Lword,
    Real,
    Lreal,
    Time,
    Ltime,
    Date,
    Tod,
    Dt,
    /// A single-byte character (Windows-1252, as STRING's), its code 0..255.
    Char,
    /// A UTF-16 code unit, as WSTRING's characters, 0..65535.
    Wchar,
}

pub const ELEMS: [Elem; 22] = [
    Elem::Bool,
    Elem::Sint,
    Elem::Int,
    Elem::Dint,
    Elem::Lint,
    Elem::Usint,
    Elem::Uint,
    Elem::Udint,
    Elem::Ulint,
    Elem::Byte,
    Elem::Word,
    Elem::Dword,
    Elem::Lword,
    Elem::Real,
    Elem::Lreal,
    Elem::Time,
    Elem::Ltime,
    Elem::Date,
    Elem::Tod,
    Elem::Dt,
    Elem::Char,
    Elem::Wchar,
];

impl Elem {
    pub fn name(self) -> &'static str {
        match self {
            Elem::Bool => "BOOL",
            Elem::Sint => "SINT",
            Elem::Int => "INT",
            Elem::Dint => "DINT",
            Elem::Lint => "LINT",
            Elem::Usint => "USINT",
            Elem::Uint => "UINT",
            Elem::Udint => "UDINT",
            Elem::Ulint => "ULINT",
            Elem::Byte => "BYTE",
            Elem::Word => "WORD",
            Elem::Dword => "DWORD",
            Elem::Lword => "LWORD",
            Elem::Real => "REAL",
            Elem::Lreal => "LREAL",
            Elem::Time => "TIME",
            Elem::Ltime => "LTIME",
            Elem::Date => "DATE",
            Elem::Tod => "TOD",
            Elem::Dt => "DT",
            Elem::Char => "CHAR",
            Elem::Wchar => "WCHAR",
        }
    }

    /// The elementary type a name spells (case-insensitive), with the standard's long forms.
    pub fn from_name(name: &str) -> Option<Elem> {
        let n = name.to_ascii_uppercase();
        Some(match n.as_str() {
            "TIME_OF_DAY" | "LTOD" | "LTIME_OF_DAY" => Elem::Tod,
            "DATE_AND_TIME" | "LDT" | "LDATE_AND_TIME" => Elem::Dt,
            "LDATE" => Elem::Date,
            _ => return ELEMS.iter().copied().find(|e| e.name() == n),
        })
    }

    pub fn index(self) -> u32 {
        ELEMS.iter().position(|&e| e == self).unwrap_or(0) as u32
    }

    pub fn is_signed(self) -> bool {
        matches!(self, Elem::Sint | Elem::Int | Elem::Dint | Elem::Lint)
    }

    pub fn is_unsigned(self) -> bool {
        matches!(self, Elem::Usint | Elem::Uint | Elem::Udint | Elem::Ulint)
    }

    /// CHAR or WCHAR (ANY_CHAR).
    pub fn is_char(self) -> bool {
        matches!(self, Elem::Char | Elem::Wchar)
    }

    /// ANY_INT.
    pub fn is_int(self) -> bool {
        self.is_signed() || self.is_unsigned()
    }

    /// BYTE, WORD, DWORD, LWORD (ANY_BIT without BOOL).
    pub fn is_bitstring(self) -> bool {
        matches!(self, Elem::Byte | Elem::Word | Elem::Dword | Elem::Lword)
    }

    /// ANY_BIT.
    pub fn is_bit(self) -> bool {
        self == Elem::Bool || self.is_bitstring()
    }

    /// ANY_REAL.
    pub fn is_real(self) -> bool {
        matches!(self, Elem::Real | Elem::Lreal)
    }

    /// ANY_NUM.
    pub fn is_num(self) -> bool {
        self.is_int() || self.is_real()
    }

    /// ANY_DURATION.
    pub fn is_duration(self) -> bool {
        matches!(self, Elem::Time | Elem::Ltime)
    }

    /// ANY_DATE.
    pub fn is_date(self) -> bool {
        matches!(self, Elem::Date | Elem::Tod | Elem::Dt)
    }

    /// Whether values are whole numbers kept in an i64 slot (everything but the reals).
    pub fn is_integral(self) -> bool {
        !self.is_real()
    }

    /// Width in bits.
    pub fn bits(self) -> u32 {
        match self {
            Elem::Bool => 1,
            Elem::Sint | Elem::Usint | Elem::Byte | Elem::Char => 8,
            Elem::Int | Elem::Uint | Elem::Word | Elem::Wchar => 16,
            Elem::Dint | Elem::Udint | Elem::Dword | Elem::Real => 32,
            _ => 64,
        }
    }

    /// The range of an integral type's values.
    pub fn range(self) -> (i128, i128) {
        match self {
            Elem::Bool => (0, 1),
            Elem::Sint => (i8::MIN as i128, i8::MAX as i128),
            Elem::Int => (i16::MIN as i128, i16::MAX as i128),
            Elem::Dint => (i32::MIN as i128, i32::MAX as i128),
            Elem::Lint | Elem::Time | Elem::Ltime | Elem::Date | Elem::Tod | Elem::Dt => {
                (i64::MIN as i128, i64::MAX as i128)
            }
            Elem::Usint | Elem::Byte | Elem::Char => (0, u8::MAX as i128),
            Elem::Uint | Elem::Word | Elem::Wchar => (0, u16::MAX as i128),
            Elem::Udint | Elem::Dword => (0, u32::MAX as i128),
            Elem::Ulint | Elem::Lword => (0, u64::MAX as i128),
            Elem::Real | Elem::Lreal => (i128::MIN, i128::MAX),
        }
    }

    /// Whether a value of `self` converts implicitly to `to` (widening without loss, as the
    /// standard's implicit conversions: SINT→INT→DINT→LINT, USINT→UINT→UDINT→ULINT,
    /// unsigned to a wider signed type, up-to-16-bit integers to REAL, up-to-32-bit integers
    /// and REAL to LREAL, BYTE→WORD→DWORD→LWORD, TIME→LTIME).
    pub fn widens_to(self, to: Elem) -> bool {
        use Elem::*;
        if self == to {
            return true;
        }
        matches!(
            (self, to),
            (Sint, Int | Dint | Lint)
                | (Int, Dint | Lint)
                | (Dint, Lint)
                | (Usint, Uint | Udint | Ulint)
                | (Uint, Udint | Ulint)
                | (Udint, Ulint)
                | (Usint, Int | Dint | Lint)
                | (Uint, Dint | Lint)
                | (Udint, Lint)
                | (Sint | Int | Usint | Uint, Real | Lreal)
                | (Dint | Udint | Real, Lreal)
                | (Byte, Word | Dword | Lword)
                | (Word, Dword | Lword)
                | (Dword, Lword)
                | (Time, Ltime)
        )
    }
}

/// A function block type: one written in a source, or one built into the engine (the
/// standard FBs, and FBs implemented in Rust).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FbRef {
    User(u32),
    Native(u32),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub name: String,
    pub ty: TypeId,
    pub init: Option<Value>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Type {
    Elem(Elem),
    /// `STRING[len]`, `len` bytes at most; `WSTRING[len]` (`wide`), `len` UTF-16 code
    /// units at most (CODESYS and TwinCAT store UCS-2/UTF-16).
    Str {
        len: u32,
        wide: bool,
    },
    /// Dimensions as inclusive bounds, outermost first.
    Array {
        dims: Vec<(i64, i64)>,
        elem: TypeId,
    },
    /// `ARRAY[*, …] OF elem`, `dims` dimensions: a VAR_IN_OUT's type only, bound to any
    /// array of that element type and number of dimensions; the bounds travel with the
    /// reference (iec-vm's in-out descriptor).
    VarArray {
        dims: u32,
        elem: TypeId,
    },
    Struct {
        name: String,
        fields: Vec<Field>,
    },
    Enum {
        name: String,
        values: Vec<(String, i64)>,
    },
    /// A subrange of an integer type: assignments are checked against it.
    Subrange {
        base: Elem,
        lo: i128,
        hi: i128,
    },
    Fb(FbRef),
    /// `REF_TO T`, `POINTER TO T`, `REFERENCE TO T`: a checked handle to a variable of type
    /// `target` (docs/iec.md, "References and pointers"), one slot.
    Ref {
        kind: RefKind,
        target: TypeId,
    },
    /// `NULL`, which converts to every reference type.
    Null,
    /// An integer literal whose type the context decides.
    IntLit,
    /// A real literal whose type the context decides.
    RealLit,
    /// What a call without a result gives.
    Void,
    /// The type of an expression that had an error (no further messages about it).
    Error,
}

pub type TypeId = u32;

/// Ids fixed for every table.
pub mod ids {
    use super::TypeId;
    pub const BOOL: TypeId = 0;
    pub const SINT: TypeId = 1;
    pub const INT: TypeId = 2;
    pub const DINT: TypeId = 3;
    pub const LINT: TypeId = 4;
    pub const USINT: TypeId = 5;
    pub const UINT: TypeId = 6;
    pub const UDINT: TypeId = 7;
    pub const ULINT: TypeId = 8;
    pub const BYTE: TypeId = 9;
    pub const WORD: TypeId = 10;
    pub const DWORD: TypeId = 11;
    pub const LWORD: TypeId = 12;
    pub const REAL: TypeId = 13;
    pub const LREAL: TypeId = 14;
    pub const TIME: TypeId = 15;
    pub const LTIME: TypeId = 16;
    pub const DATE: TypeId = 17;
    pub const TOD: TypeId = 18;
    pub const DT: TypeId = 19;
    pub const CHAR: TypeId = 20;
    pub const WCHAR: TypeId = 21;
    pub const INT_LIT: TypeId = 22;
    pub const REAL_LIT: TypeId = 23;
    pub const VOID: TypeId = 24;
    pub const ERROR: TypeId = 25;
    /// `STRING` without a length: 254 characters.
    pub const STRING: TypeId = 26;
    /// `WSTRING` without a length: as many characters as `STRING`.
    pub const WSTRING: TypeId = 27;
}

/// The default length of `STRING`.
pub const DEFAULT_STRING_LEN: u32 = 254;
/// The longest string accepted.
pub const MAX_STRING_LEN: u32 = 65_535;

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum Key {
    Str(u32, bool),
    Array(Vec<(i64, i64)>, TypeId),
    VarArray(u32, TypeId),
    Subrange(Elem, i128, i128),
    Fb(FbRef),
    Ref(RefKind, TypeId),
    Null,
}

/// Every type of a compilation.
#[derive(Clone, Debug)]
pub struct TypeTable {
    types: Vec<Type>,
    interned: HashMap<Key, TypeId>,
    /// CODESYS's and TwinCAT's UNIONs: each is a [`Type::Struct`] of one field, the union's
    /// bytes (an `ARRAY[0..n-1] OF BYTE`), and here its members, which all start at byte 0
    /// and are read and written through that byte image (`memory`, iec-vm's `pointer.rs`).
    unions: HashMap<TypeId, Vec<Field>>,
}

impl Default for TypeTable {
    fn default() -> Self {
        Self::new()
    }
}

impl TypeTable {
    pub fn new() -> Self {
        let mut t = TypeTable {
            types: ELEMS.iter().map(|&e| Type::Elem(e)).collect(),
            interned: HashMap::new(),
            unions: HashMap::new(),
        };
        t.types.push(Type::IntLit);
        t.types.push(Type::RealLit);
        t.types.push(Type::Void);
        t.types.push(Type::Error);
        let s = t.string(DEFAULT_STRING_LEN);
        debug_assert_eq!(s, ids::STRING);
        let w = t.wstring(DEFAULT_STRING_LEN);
        debug_assert_eq!(w, ids::WSTRING);
        t
    }

    pub fn get(&self, id: TypeId) -> &Type {
        &self.types[id as usize]
    }

    pub fn len(&self) -> usize {
        self.types.len()
    }

    pub fn is_empty(&self) -> bool {
        self.types.is_empty()
    }

    pub fn elem_id(e: Elem) -> TypeId {
        e.index()
    }

    fn intern(&mut self, key: Key, ty: Type) -> TypeId {
        if let Some(&id) = self.interned.get(&key) {
            return id;
        }
        let id = self.types.len() as TypeId;
        self.types.push(ty);
        self.interned.insert(key, id);
        id
    }

    pub fn string(&mut self, len: u32) -> TypeId {
        self.intern(Key::Str(len, false), Type::Str { len, wide: false })
    }

    pub fn wstring(&mut self, len: u32) -> TypeId {
        self.intern(Key::Str(len, true), Type::Str { len, wide: true })
    }

    /// A string type of `len` characters, wide or not.
    pub fn string_of(&mut self, len: u32, wide: bool) -> TypeId {
        if wide {
            self.wstring(len)
        } else {
            self.string(len)
        }
    }

    /// Whether the type is `WSTRING[n]`.
    pub fn is_wstring(&self, id: TypeId) -> bool {
        matches!(self.get(id), Type::Str { wide: true, .. })
    }

    pub fn array(&mut self, dims: Vec<(i64, i64)>, elem: TypeId) -> TypeId {
        self.intern(Key::Array(dims.clone(), elem), Type::Array { dims, elem })
    }

    /// `ARRAY[*, …] OF elem` of `dims` dimensions.
    pub fn var_array(&mut self, dims: u32, elem: TypeId) -> TypeId {
        self.intern(Key::VarArray(dims, elem), Type::VarArray { dims, elem })
    }

    /// Whether the type is an `ARRAY[*]`.
    pub fn is_var_array(&self, id: TypeId) -> bool {
        matches!(self.get(id), Type::VarArray { .. })
    }

    /// An array's number of dimensions and element type (fixed bounds or `ARRAY[*]`).
    pub fn array_shape(&self, id: TypeId) -> Option<(u32, TypeId)> {
        match self.get(id) {
            Type::Array { dims, elem } => Some((dims.len() as u32, *elem)),
            Type::VarArray { dims, elem } => Some((*dims, *elem)),
            _ => None,
        }
    }

    pub fn subrange(&mut self, base: Elem, lo: i128, hi: i128) -> TypeId {
        self.intern(Key::Subrange(base, lo, hi), Type::Subrange { base, lo, hi })
    }

    pub fn fb(&mut self, r: FbRef) -> TypeId {
        self.intern(Key::Fb(r), Type::Fb(r))
    }

    /// The type of a function block's (or program's) instances, if any variable has it yet.
    pub fn fb_id(&self, r: FbRef) -> Option<TypeId> {
        self.types
            .iter()
            .position(|t| matches!(t, Type::Fb(x) if *x == r))
            .map(|i| i as TypeId)
    }

    pub fn reference(&mut self, kind: RefKind, target: TypeId) -> TypeId {
        self.intern(Key::Ref(kind, target), Type::Ref { kind, target })
    }

    /// The type of `NULL`.
    pub fn null(&mut self) -> TypeId {
        self.intern(Key::Null, Type::Null)
    }

    /// Whether a value of the type holds a reference anywhere (in a field or an element).
    pub fn holds_reference(&self, id: TypeId) -> bool {
        match self.get(id) {
            Type::Ref { .. } | Type::Null => true,
            Type::Array { elem, .. } | Type::VarArray { elem, .. } => self.holds_reference(*elem),
            Type::Struct { fields, .. } => fields.iter().any(|f| self.holds_reference(f.ty)),
            _ => false,
        }
    }

    /// What a reference or pointer type designates (`None` for other types).
    pub fn ref_target(&self, id: TypeId) -> Option<TypeId> {
        match self.get(id) {
            Type::Ref { target, .. } => Some(*target),
            _ => None,
        }
    }

    /// Makes the structure `id` a UNION of `members` (its one field holds the bytes).
    pub fn set_union(&mut self, id: TypeId, members: Vec<Field>) {
        self.unions.insert(id, members);
    }

    /// The members of a UNION (`None`: `id` is no union).
    pub fn union_members(&self, id: TypeId) -> Option<&[Field]> {
        self.unions.get(&id).map(Vec::as_slice)
    }

    /// A named (nominal) type: a new id every time.
    pub fn add(&mut self, ty: Type) -> TypeId {
        let id = self.types.len() as TypeId;
        self.types.push(ty);
        id
    }

    /// Replaces a type added earlier (a structure filled in after its fields resolve).
    pub fn set(&mut self, id: TypeId, ty: Type) {
        self.types[id as usize] = ty;
    }

    /// The elementary type of a scalar (a subrange's base, an enumeration's DINT-like values
    /// are not elementary: `None`).
    pub fn elem(&self, id: TypeId) -> Option<Elem> {
        match self.get(id) {
            Type::Elem(e) => Some(*e),
            Type::Subrange { base, .. } => Some(*base),
            _ => None,
        }
    }

    /// Whether values of the type fit one 64-bit slot (elementary, enumerations, subranges).
    pub fn is_scalar(&self, id: TypeId) -> bool {
        matches!(
            self.get(id),
            Type::Elem(_)
                | Type::Enum { .. }
                | Type::Subrange { .. }
                | Type::Ref { .. }
                | Type::Null
        )
    }

    pub fn is_string(&self, id: TypeId) -> bool {
        matches!(self.get(id), Type::Str { .. })
    }

    /// The type as the standard writes it, for messages.
    pub fn name(&self, id: TypeId) -> String {
        match self.get(id) {
            Type::Elem(e) => e.name().to_string(),
            Type::Str { len, wide } => {
                let n = if *wide { "WSTRING" } else { "STRING" };
                if *len == DEFAULT_STRING_LEN {
                    n.into()
                } else {
                    format!("{n}[{len}]")
                }
            }
            Type::Array { dims, elem } => format!(
                "ARRAY[{}] OF {}",
                dims.iter()
                    .map(|(l, h)| format!("{l}..{h}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                self.name(*elem)
            ),
            Type::VarArray { dims, elem } => format!(
                "ARRAY[{}] OF {}",
                vec!["*"; *dims as usize].join(", "),
                self.name(*elem)
            ),
            Type::Struct { name, .. } | Type::Enum { name, .. } => name.clone(),
            Type::Subrange { base, lo, hi } => format!("{} ({lo}..{hi})", base.name()),
            Type::Fb(_) => "function block".into(),
            // An interface's type is named as the interface (its target a marker of that name).
            Type::Ref {
                kind: RefKind::Interface,
                target,
            } => self.name(*target),
            Type::Ref { kind, target } => format!("{} {}", kind.text(), self.name(*target)),
            Type::Null => "NULL".into(),
            Type::IntLit => "an integer literal".into(),
            Type::RealLit => "a real literal".into(),
            Type::Void => "no value".into(),
            Type::Error => "?".into(),
        }
    }

    /// Number of array elements (1 for a non-array).
    pub fn element_count(&self, id: TypeId) -> u64 {
        match self.get(id) {
            Type::Array { dims, .. } => dims
                .iter()
                .map(|(l, h)| (h - l + 1).max(0) as u64)
                .product(),
            _ => 1,
        }
    }
}

/// Whether an integer value lies in the range of an integral type.
pub fn fits(v: i128, e: Elem) -> bool {
    let (lo, hi) = e.range();
    (lo..=hi).contains(&v)
}

/// The value kept in `e`'s bits (two's complement wrap-around), as type conversions between
/// integer types keep the low bits.
pub fn wrap(v: i128, e: Elem) -> i128 {
    match e {
        Elem::Bool => (v != 0) as i128,
        Elem::Sint => v as i8 as i128,
        Elem::Int => v as i16 as i128,
        Elem::Dint => v as i32 as i128,
        Elem::Usint | Elem::Byte => v as u8 as i128,
        Elem::Uint | Elem::Word => v as u16 as i128,
        Elem::Udint | Elem::Dword => v as u32 as i128,
        Elem::Ulint | Elem::Lword => v as u64 as i128,
        _ => v as i64 as i128,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_ids_match_the_elementary_order() {
        let mut t = TypeTable::new();
        assert_eq!(t.get(ids::LREAL), &Type::Elem(Elem::Lreal));
        assert_eq!(t.get(ids::DT), &Type::Elem(Elem::Dt));
        assert_eq!(
            t.get(ids::STRING),
            &Type::Str {
                len: 254,
                wide: false
            }
        );
        assert_eq!(t.name(ids::WSTRING), "WSTRING");
        let w8 = t.wstring(8);
        assert_eq!(t.name(w8), "WSTRING[8]");
        assert_eq!(TypeTable::elem_id(Elem::Word), ids::WORD);
    }

    #[test]
    fn interning() {
        let mut t = TypeTable::new();
        let a = t.array(vec![(1, 3)], ids::INT);
        let b = t.array(vec![(1, 3)], ids::INT);
        let c = t.array(vec![(0, 2)], ids::INT);
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_eq!(t.string(254), ids::STRING);
        assert_eq!(t.name(a), "ARRAY[1..3] OF INT");
        let v = t.var_array(2, ids::INT);
        assert_eq!(v, t.var_array(2, ids::INT));
        assert_ne!(v, t.var_array(1, ids::INT));
        assert_eq!(t.name(v), "ARRAY[*, *] OF INT");
        assert_eq!(t.array_shape(a), Some((1, ids::INT)));
        assert_eq!(t.array_shape(v), Some((2, ids::INT)));
    }

    #[test]
    fn wrapping_and_ranges() {
        assert_eq!(wrap(200, Elem::Sint), -56);
        assert_eq!(wrap(-1, Elem::Uint), 65535);
        assert_eq!(wrap(70000, Elem::Int), 4464);
        assert_eq!(wrap(5, Elem::Bool), 1);
        assert!(fits(-128, Elem::Sint));
        assert!(!fits(128, Elem::Sint));
        assert!(fits(u64::MAX as i128, Elem::Ulint));
    }

    #[test]
    fn widening() {
        assert!(Elem::Sint.widens_to(Elem::Lint));
        assert!(Elem::Usint.widens_to(Elem::Int));
        assert!(!Elem::Int.widens_to(Elem::Uint));
        assert!(!Elem::Dint.widens_to(Elem::Real));
        assert!(Elem::Dint.widens_to(Elem::Lreal));
        assert!(!Elem::Real.widens_to(Elem::Int));
        assert!(Elem::Byte.widens_to(Elem::Lword));
        assert!(!Elem::Bool.widens_to(Elem::Byte));
        assert!(Elem::Time.widens_to(Elem::Ltime));
        assert_eq!(Elem::from_name("time_of_day"), Some(Elem::Tod));
        assert_eq!(Elem::from_name("udint"), Some(Elem::Udint));
        assert_eq!(Elem::from_name("STRING"), None);
    }
}
