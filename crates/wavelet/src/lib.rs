//! Wavelet fog (paper E: Giroud & Biri, real-time heterogeneous fog on B-spline wavelets).

pub mod basis;
pub mod mallat;
