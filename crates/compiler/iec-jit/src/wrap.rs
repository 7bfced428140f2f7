//! Wrapping integer arithmetic as machine code: the VM's `ArNW`/`ArLW`/`ArUW`/`NegNW`
//! meaning (64-bit modular arithmetic, then the type's low bits), inline.

use cranelift_codegen::ir::{InstBuilder, Value};
use cranelift_frontend::FunctionBuilder;
use petriplc_iec_vm::op::{Arith, WIDTHS};

/// `x op y` in 64 bits, wrapping (Cranelift's integer arithmetic is modular); `op` is
/// `+`, `-` or `*` (the others can fault and are the VM's).
pub fn wrapping(b: &mut FunctionBuilder<'_>, op: Arith, x: Value, y: Value) -> Value {
    match op {
        Arith::Add => b.ins().iadd(x, y),
        Arith::Sub => b.ins().isub(x, y),
        _ => b.ins().imul(x, y),
    }
}

/// The low bits of range `r`'s type, sign- or zero-extended: the VM's `op::wrap_to`.
pub fn wrap_to(b: &mut FunctionBuilder<'_>, v: Value, r: u8) -> Value {
    let (bits, signed) = WIDTHS[r as usize];
    if bits >= 64 {
        v
    } else if signed {
        let sh = 64 - i64::from(bits);
        let l = b.ins().ishl_imm(v, sh);
        b.ins().sshr_imm(l, sh)
    } else {
        b.ins().band_imm(v, (1i64 << bits) - 1)
    }
}
