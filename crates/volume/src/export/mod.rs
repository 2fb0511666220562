//! Taking volumes out: a dense volume written as a file other tools read.

pub mod vdb;
