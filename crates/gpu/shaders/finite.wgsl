// Tests for values that overflowed or came from 0/0 (a module, `#import finite`).

// False for NaN (every comparison with it is) and ±inf.
fn finite(v: f32) -> bool {
    return abs(v) <= 3.4028235e38;
}

// v where it is finite, else 0.
fn finite_or_zero(v: f32) -> f32 {
    return select(0.0, v, finite(v));
}
