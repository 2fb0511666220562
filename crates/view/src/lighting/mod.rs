//! Source radiance at the RBF centers (paper A §5.3–5.4).

pub mod direct;
pub mod single;
pub mod zh_table;
