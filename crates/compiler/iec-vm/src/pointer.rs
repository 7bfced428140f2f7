//! References and pointers as the VM keeps them: one slot holding a checked handle, never a
//! raw address a program could forge (docs/iec.md, "References and pointers").
//!
//! A handle is the designated variable's absolute slot in the low 32 bits and its type's id
//! plus one (the tag) in the high 32 bits; `NULL` is 0. Handles are only made by `REF`/`ADR`
//! of a variable with a lasting address (the checker's rule E201: globals, program and
//! function block variables, all at fixed places for the machine's life), copied, and
//! compared. Every dereference checks the tag against the type the code expects and the
//! extent against the memory, so a NULL or foreign handle is a fault, never a wrong access.

use petriplc_iec_sema::ops::OpError;

use crate::ext::OpFault;

/// The handle of the variable at absolute slot `addr` of type id `ty`.
pub fn encode(addr: u64, ty: u32) -> u64 {
    (u64::from(ty) + 1) << 32 | (addr & 0xffff_ffff)
}

/// `mem[base + d] = handle of (mem[base + s], ty)`.
pub fn make(mem: &mut [u64], base: usize, d: u32, s: u32, ty: u32) {
    let addr = mem[base + s as usize];
    mem[base + d as usize] = encode(addr, ty);
}

/// `mem[base + d] = address` the handle in `mem[base + p]` designates, checked: not NULL,
/// made for type `ty`, its `n` slots inside the memory. `what` names the reference type for
/// the message.
pub fn deref(
    mem: &mut [u64],
    base: usize,
    d: u32,
    p: u32,
    ty: u32,
    n: u32,
    what: &str,
) -> Result<(), OpFault> {
    let h = mem[base + p as usize];
    if h == 0 {
        return Err(OpFault::new(
            OpError::Domain("NULL dereferenced"),
            format!("this {what} is NULL; set it with REF(x)/ADR(x) or test `<> NULL` first"),
        ));
    }
    let tag = h >> 32;
    let addr = h & 0xffff_ffff;
    if tag != u64::from(ty) + 1 || addr + u64::from(n) > mem.len() as u64 {
        return Err(OpFault::new(
            OpError::Domain("invalid reference"),
            format!("this {what} does not designate a variable of its type"),
        ));
    }
    mem[base + d as usize] = addr;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn handles_round_trip_and_are_checked() {
        let mut mem = vec![0u64; 8];
        mem[1] = 5; // an address
        make(&mut mem, 0, 2, 1, 3);
        assert_ne!(mem[2], 0, "a handle is never NULL");
        deref(&mut mem, 0, 4, 2, 3, 1, "REF_TO INT").unwrap();
        assert_eq!(mem[4], 5);
        // Another type's view of the same variable is refused.
        let e = deref(&mut mem, 0, 4, 2, 7, 1, "REF_TO REAL").unwrap_err();
        assert_eq!(e.error, OpError::Domain("invalid reference"));
        // So is one that would reach past the memory, and NULL.
        assert!(deref(&mut mem, 0, 4, 2, 3, 4, "REF_TO T").is_err());
        let e = deref(&mut mem, 0, 4, 0, 3, 1, "REF_TO INT").unwrap_err();
        assert_eq!(e.error, OpError::Domain("NULL dereferenced"));
    }
}
