//! What CODESYS keeps in PLCopen XML's `<addData>` (its `http://www.3s-software.com/plcopenxml/…`
//! data): global variable lists of the project, programs of a resource (a device's application),
//! the blocks of a global list whose variables differ in attributes; a POU's methods,
//! properties, EXTENDS and IMPLEMENTS, and the actions of a POU whose body is not SFC; and
//! interfaces (`<Interface>`, with their methods, properties and bases). A task's interval may be an XML duration (`PT0.05S`), as CODESYS writes it. Other data (object ids, attributes, folders, task settings) changes nothing here.

use super::{Reader, X};
use crate::ast::*;
use crate::diag;

/// The names of CODESYS's data, after `http://www.3s-software.com/plcopenxml/`.
fn data<'a>(holder: &'a X, kind: &'a str) -> impl Iterator<Item = &'a X> + 'a {
    holder
        .children_named("addData")
        .flat_map(|a| a.children_named("data"))
        .filter(move |d| {
            d.attr("name").is_some_and(|n| {
                n.strip_prefix("http://www.3s-software.com/plcopenxml/")
                    .is_some_and(|k| k.eq_ignore_ascii_case(kind))
            })
        })
}

impl Reader<'_> {
    /// A `<globalVars>` block, or the blocks of its `MixedAttrsVarList` when CODESYS wrote
    /// one: then the block itself holds every variable under the first block's attributes.
    pub(super) fn global_vars(&mut self, b: &X) -> Vec<VarBlock> {
        let mixed: Vec<&X> = data(b, "mixedattrsvarlist")
            .flat_map(|d| d.children_named("MixedAttrsVarList"))
            .flat_map(|m| m.children_named("globalVars"))
            .collect();
        if mixed.is_empty() {
            return vec![self.var_block(b, VarKind::Global)];
        }
        mixed
            .into_iter()
            .map(|m| self.var_block(m, VarKind::Global))
            .collect()
    }

    /// The project's own data: global variable lists, interfaces.
    pub(super) fn project_add_data(&mut self, root: &X) {
        for d in data(root, "globalvars") {
            for b in d.children_named("globalVars") {
                for block in self.global_vars(b) {
                    self.found.push(Element::Globals(block));
                }
            }
        }
        for d in data(root, "interface") {
            for i in d.children_named("Interface") {
                if let Some(p) = self.interface_pou(i) {
                    self.found.push(Element::Pou(p));
                }
            }
        }
    }

    /// An `<Interface>`: its methods (`<Methods>` or `<addData>` method data, declarations
    /// only), properties (a `<GetAccessor>`/`<SetAccessor>` says which accessors it has,
    /// both when neither is there) and the interfaces it extends (`<Extends>` under an
    /// `<Inheritance>`, or its own `<Extends>`), as the interface POU the text parser reads.
    fn interface_pou(&mut self, i: &X) -> Option<Pou> {
        let name = self.name_attr(i)?;
        let mut oop = PouOop {
            interface: true,
            ..PouOop::default()
        };
        let listed = |tag: &'static str, kind: &'static str, item: &'static str| {
            i.children_named(tag)
                .flat_map(move |m| m.children_named(item))
                .chain(data(i, kind).flat_map(move |d| d.children_named(item)))
                .collect::<Vec<&X>>()
        };
        for m in listed("Methods", "method", "Method") {
            if let Some(mut pou) = self.member_pou(m) {
                pou.body = Body::St(Vec::new());
                oop.methods.push(Method {
                    modifiers: Modifiers {
                        is_abstract: true,
                        ..Modifiers::default()
                    },
                    pou,
                });
            }
        }
        for p in listed("Properties", "property", "Property") {
            let abstract_ = Modifiers {
                is_abstract: true,
                ..Modifiers::default()
            };
            let owner = format!("INTERFACE {}", name.name);
            let Some(mut prop) = self.property_head(p, &owner, abstract_) else {
                continue;
            };
            let (mut get, mut set) = (
                p.child("GetAccessor").is_some(),
                p.child("SetAccessor").is_some(),
            );
            if !get && !set {
                (get, set) = (true, true);
            }
            let span = prop.span;
            if get {
                prop.get = Some(crate::parser::accessor(
                    &prop,
                    true,
                    Vec::new(),
                    Body::St(Vec::new()),
                    span,
                ));
            }
            if set {
                prop.set = Some(crate::parser::accessor(
                    &prop,
                    false,
                    Vec::new(),
                    Body::St(Vec::new()),
                    span,
                ));
            }
            oop.properties.push(prop);
        }
        let inherits = i
            .children_named("Inheritance")
            .chain(data(i, "pouinheritance").flat_map(|d| d.children_named("Inheritance")))
            .flat_map(|h| h.children_named("Extends"))
            .chain(i.children_named("Extends"));
        for e in inherits {
            let span = self.span(e);
            for n in e.text.split(',').map(str::trim).filter(|n| !n.is_empty()) {
                oop.implements.push(Ident::new(n, span));
            }
        }
        Some(Pou {
            kind: PouKind::FunctionBlock,
            span: name.span,
            name,
            return_type: None,
            var_blocks: Vec::new(),
            body: Body::St(Vec::new()),
            oop: Box::new(oop),
        })
    }

    /// A resource's data: the programs of the application CODESYS exports with its device.
    pub(super) fn resource_add_data(&mut self, r: &X) {
        for d in data(r, "pou") {
            for p in d.children_named("pou") {
                if let Some(p) = self.pou(p) {
                    self.found.push(Element::Pou(p));
                }
            }
        }
    }

    /// A `<Property>` of `owner` (named in messages) without its accessors: its name and the
    /// type of its `<returnType>` (`None`, reported, when either is missing).
    fn property_head(&mut self, p: &X, owner: &str, modifiers: Modifiers) -> Option<Property> {
        let pname = self.name_attr(p)?;
        let (_, ty) = self.interface_of(p);
        let Some(ty) = ty else {
            let span = self.span(p);
            self.diags.error(
                diag::PLCOPEN_STRUCTURE,
                span,
                format!(
                    "PROPERTY {} of {owner} has no <returnType> in its <interface>",
                    pname.name
                ),
            );
            return None;
        };
        Some(Property {
            modifiers,
            span: pname.span,
            name: pname,
            ty,
            get: None,
            set: None,
        })
    }

    /// A POU's data: its methods, properties (`<GetAccessor>`, `<SetAccessor>`), EXTENDS and
    /// IMPLEMENTS, and its actions when its body is not SFC (whose actions are its steps').
    pub(super) fn pou_add_data(&mut self, pou: &X, name: &Ident) -> PouOop {
        let mut oop = PouOop::default();
        for d in data(pou, "method") {
            for m in d.children_named("Method") {
                if let Some(method) = self.member_pou(m) {
                    oop.methods.push(Method {
                        modifiers: Modifiers::default(),
                        pou: method,
                    });
                }
            }
        }
        for d in data(pou, "property") {
            for p in d.children_named("Property") {
                let Some(mut prop) = self.property_head(p, &name.name, Modifiers::default()) else {
                    continue;
                };
                let pname = prop.name.clone();
                for (tag, get) in [("GetAccessor", true), ("SetAccessor", false)] {
                    if let Some(acc) = p.child(tag) {
                        let (blocks, _) = self.interface_of(acc);
                        let body = self.body(acc, &pname);
                        let span = self.span(acc);
                        let pou = crate::parser::accessor(&prop, get, blocks, body, span);
                        if get {
                            prop.get = Some(pou);
                        } else {
                            prop.set = Some(pou);
                        }
                    }
                }
                oop.properties.push(prop);
            }
        }
        for d in data(pou, "pouinheritance") {
            for i in d.children_named("Inheritance") {
                for e in i.children_named("Extends") {
                    let span = self.span(e);
                    oop.extends = Some(Ident::new(e.text.trim(), span));
                }
                for e in i.children_named("Implements") {
                    let span = self.span(e);
                    for n in e.text.split(',').map(str::trim).filter(|n| !n.is_empty()) {
                        oop.implements.push(Ident::new(n, span));
                    }
                }
            }
        }
        let sfc = pou
            .child("body")
            .is_some_and(|b| b.children.iter().any(|c| c.name == "SFC"));
        if !sfc {
            for a in pou
                .child("actions")
                .into_iter()
                .flat_map(|a| a.children_named("action"))
            {
                let Some(aname) = self.name_attr(a) else {
                    continue;
                };
                let body = self.body(a, &aname);
                let span = aname.span;
                oop.actions.push(Action {
                    name: aname,
                    body,
                    span,
                });
            }
        }
        oop
    }

    /// A `<Method>`: a FUNCTION-like POU of its interface and body.
    fn member_pou(&mut self, m: &X) -> Option<Pou> {
        let name = self.name_attr(m)?;
        let (var_blocks, return_type) = self.interface_of(m);
        let body = self.body(m, &name);
        Some(Pou {
            kind: PouKind::Function,
            span: name.span,
            name,
            return_type,
            var_blocks,
            body,
            oop: Box::default(),
        })
    }
}

/// An XML Schema duration (`PT0.05S`, `PT1M30S`, `P1DT2H`) in nanoseconds; `None` for anything
/// else (an IEC literal such as `T#20ms` is parsed as one).
pub(super) fn iso_duration(text: &str) -> Option<i128> {
    let rest = text.trim().strip_prefix('P')?;
    let (days, time) = match rest.split_once('T') {
        Some((d, t)) => (d, t),
        None => (rest, ""),
    };
    let mut total: i128 = 0;
    let mut any = false;
    let mut add = |part: &str, units: &[(char, i128)]| -> Option<()> {
        let mut num = String::new();
        for c in part.chars() {
            if c.is_ascii_digit() || c == '.' {
                num.push(c);
                continue;
            }
            let scale = units.iter().find(|(u, _)| *u == c.to_ascii_uppercase())?.1;
            let (whole, frac) = num.split_once('.').unwrap_or((&num, ""));
            if whole.is_empty() && frac.is_empty() {
                return None;
            }
            let whole: i128 = if whole.is_empty() {
                0
            } else {
                whole.parse().ok()?
            };
            let mut f: i128 = 0;
            let mut div: i128 = 1;
            for d in frac.chars().take(18) {
                f = f * 10 + i128::from(d.to_digit(10)?);
                div *= 10;
            }
            total = total.checked_add(whole.checked_mul(scale)? + f * scale / div)?;
            any = true;
            num.clear();
        }
        num.is_empty().then_some(())
    };
    const S: i128 = 1_000_000_000;
    add(days, &[('D', 86_400 * S)])?;
    add(time, &[('H', 3_600 * S), ('M', 60 * S), ('S', S)])?;
    any.then_some(total)
}

#[cfg(test)]
mod tests {
    use super::iso_duration;

    #[test]
    fn xml_durations() {
        assert_eq!(iso_duration("PT0.05S"), Some(50_000_000));
        assert_eq!(iso_duration("PT10S"), Some(10_000_000_000));
        assert_eq!(iso_duration("PT1M30S"), Some(90_000_000_000));
        assert_eq!(iso_duration("P1DT2H"), Some(93_600_000_000_000));
        assert_eq!(iso_duration("PT0.000001S"), Some(1_000));
        for bad in ["T#20ms", "P", "PT", "PT5", "PTS", "PT1X", "20ms"] {
            assert_eq!(iso_duration(bad), None, "{bad}");
        }
    }
}
