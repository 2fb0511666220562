//! Paper C (Sun et al. 2005): analytic single scattering of point lights, suns and the
//! environment in a homogeneous isotropic medium — the airlight through a precomputed
//! table of its special function ([`airlight`], [`hfunc`], [`htable`]), the light the
//! medium scatters onto surfaces (the diffuse `G0` and specular `Gn` tables, [`gtable`]),
//! the environment seen and reflected through the medium with its glow in spherical
//! harmonics ([`envglow`]) — and the references that integrate the same model by
//! quadrature, independent of every table ([`reference`](mod@reference), [`envref`]). [`crate::render`]
//! renders a scene with either.

pub mod airlight;
pub mod envglow;
pub mod envref;
pub mod gtable;
pub mod hfunc;
pub mod htable;
pub mod quad;
pub mod reference;
pub mod special;
pub mod table;
