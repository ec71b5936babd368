//! The RAM self-test at power-up (seed 000 line 685: the Run LED steady on for an MCU RAM
//! fault). A word-wise March C- over all of RAM runs in `__pre_init`, before the runtime puts
//! `.data` and `.bss` there: ⇑(w0) ⇑(r0,w1) ⇑(r1,w0) ⇓(r0,w1) ⇓(r1,w0) ⇑(r0), with all-zero
//! and all-one words. It finds stuck-at, transition and address-decoder faults and coupling
//! between words. Its result is left in `.uninit`, which the runtime does not touch.
//!
//! After a pass, every word is painted with [`PAINT`]: the runtime then writes `.data` and
//! `.bss`, and the stack overwrites the paint as it grows, so the lowest word above the
//! statics that no longer holds it is the deepest the stack has been ([`stack_peak`]).
//!
//! Assembly, not Rust: nothing may touch RAM (the stack included) while it is tested, and
//! cortex-m-rt calls any Rust code this early undefined behaviour. The test uses r0-r3 and r12
//! only, and no stack.

use core::mem::MaybeUninit;

/// The marker the test leaves when every word passed.
const PASSED: u32 = 0x600D_5EED;

/// The word RAM holds after the test.
const PAINT: u32 = 0x5AC3_A53C;

/// The test's result: the marker, and the address of the first word that failed.
#[no_mangle]
#[link_section = ".uninit.RAM_TEST"]
static mut RAM_TEST: MaybeUninit<[u32; 2]> = MaybeUninit::uninit();

/// What the test found at power-up: `Err(address)` of the first failing word.
pub fn result() -> Result<(), u32> {
    // SAFETY: written by `__pre_init` before main, read once here; never written after.
    let [marker, address] = unsafe { (*core::ptr::addr_of!(RAM_TEST)).assume_init() };
    if marker == PASSED {
        Ok(())
    } else {
        Err(address)
    }
}

/// The deepest the stack has been since power-up, and its room (RAM above the statics), in
/// bytes: the lowest word between the statics and the stack's top no longer painted.
#[cfg(feature = "sim")]
pub fn stack_peak() -> (u32, u32) {
    extern "C" {
        static __sheap: u32;
        static _stack_start: u32;
    }
    // SAFETY: linker symbols: their addresses bound the stack's region, which is mapped RAM;
    // the words below the stack pointer are read, never written, as plain words.
    unsafe {
        let bottom = core::ptr::addr_of!(__sheap);
        let top = core::ptr::addr_of!(_stack_start);
        let mut at = bottom;
        while at < top && core::ptr::read_volatile(at) == PAINT {
            at = at.add(1);
        }
        let room = (top as usize - bottom as usize) as u32;
        let used = (top as usize - at as usize) as u32;
        (used, room)
    }
}

/// The March C- elements, with `$inject` between the first two: the self-test image puts a
/// stuck-at-0 bit there, as a faulty cell would show.
macro_rules! march_c {
    ($inject:literal) => {
        core::arch::global_asm!(concat!(
            ".section .text.__pre_init,\"ax\",%progbits\n",
            ".global __pre_init\n",
            ".type __pre_init,%function\n",
            ".thumb_func\n",
            "__pre_init:\n",
            "    ldr   r0, =_ram_start\n",
            "    ldr   r1, =_stack_start\n",
            "    mvn   r12, #0\n",
            // M0: up, write 0.
            "    movs  r2, #0\n",
            "    mov   r3, r0\n",
            "1:  str   r2, [r3], #4\n",
            "    cmp   r3, r1\n",
            "    bne   1b\n",
            // M1: up, read 0, write 1.
            "    mov   r3, r0\n",
            "2:  ldr   r2, [r3]\n",
            "    cmp   r2, #0\n",
            "    bne   8f\n",
            "    str   r12, [r3], #4\n",
            "    cmp   r3, r1\n",
            "    bne   2b\n",
            $inject,
            // M2: up, read 1, write 0.
            "    mov   r3, r0\n",
            "3:  ldr   r2, [r3]\n",
            "    cmp   r2, r12\n",
            "    bne   8f\n",
            "    movs  r2, #0\n",
            "    str   r2, [r3], #4\n",
            "    cmp   r3, r1\n",
            "    bne   3b\n",
            // M3: down, read 0, write 1.
            "    mov   r3, r1\n",
            "4:  ldr   r2, [r3, #-4]!\n",
            "    cmp   r2, #0\n",
            "    bne   8f\n",
            "    str   r12, [r3]\n",
            "    cmp   r3, r0\n",
            "    bne   4b\n",
            // M4: down, read 1, write 0.
            "    mov   r3, r1\n",
            "5:  ldr   r2, [r3, #-4]!\n",
            "    cmp   r2, r12\n",
            "    bne   8f\n",
            "    movs  r2, #0\n",
            "    str   r2, [r3]\n",
            "    cmp   r3, r0\n",
            "    bne   5b\n",
            // M5: up, read 0.
            "    mov   r3, r0\n",
            "6:  ldr   r2, [r3]\n",
            "    cmp   r2, #0\n",
            "    bne   8f\n",
            "    adds  r3, r3, #4\n",
            "    cmp   r3, r1\n",
            "    bne   6b\n",
            // Paint: up, write the stack's paint.
            "    ldr   r2, ={paint}\n",
            "    mov   r3, r0\n",
            "7:  str   r2, [r3], #4\n",
            "    cmp   r3, r1\n",
            "    bne   7b\n",
            "    ldr   r2, =0x600D5EED\n",
            "    movs  r3, #0\n",
            "    b     9f\n",
            // A failure: r3 holds the word's address.
            "8:  ldr   r2, =0xBAD0BAD0\n",
            "9:  ldr   r1, =RAM_TEST\n",
            "    str   r2, [r1]\n",
            "    str   r3, [r1, #4]\n",
            "    bx    lr\n",
            ".ltorg\n",
        ), paint = const PAINT);
    };
}

#[cfg(not(feature = "selftest-ramfault"))]
march_c!("");

// A cell 256 bytes into RAM with bit 4 stuck at 0: the word reads back wrong in M2.
#[cfg(feature = "selftest-ramfault")]
march_c!(
    "    ldr   r3, =_ram_start\n    ldr   r2, [r3, #256]\n    bic   r2, r2, #16\n    str   r2, [r3, #256]\n"
);
