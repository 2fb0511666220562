//! Paper B's integrated pairs, prepared once per frame and light (module docs of
//! [`crate::paper_b`]): which (light, Gaussian) pairs exceed the factorization's error
//! bound, each pair's list of Gaussians taken exactly per node (the hosts the light sits
//! inside and the pair's shadowers, [`haze_gaussians::integrated::shadowers`]), the
//! homogeneous term's list (the hosts and the fog's casters) and `C_sv` with and without
//! it.

use super::PaperBOptions;
use crate::vec3::{Vec3, norm, sub};
use haze_gaussians::airlight::{Blob, GaussianSet, Source};
use haze_gaussians::integrated::{
    MAX_EXACT, MAX_HOSTS, SUPPORT, bound, fog_casters, host_depth, shadowers,
};
use haze_gaussians::line;
use rayon::prelude::*;

/// The shadowers of integrated pairs beyond `MAX_EXACT`, left at the pairs' centres as
/// in the paper (their attenuation of the pair is then all or nothing where it is partial).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LeftAtCentres {
    /// Pairs that left any.
    pub pairs: usize,
    /// Shadowers left, over all pairs.
    pub shadows: usize,
    /// The largest left shadower's error at its pair's centre
    /// ([`haze_gaussians::integrated::shadow_error`]).
    pub largest: f64,
}

/// The integrated path's terms of one light, prepared once per frame.
#[derive(Debug)]
pub(crate) struct PairTerms {
    /// Per Gaussian: `e^{Eᵢ}` of the Gaussians but [`PairTerms::pair_exact`] (whose depths towards the
    /// light and the eye are taken per node) when the pair is integrated along the ray
    /// ([`PaperBOptions::target`]), `None` where the closed form serves.
    pub(crate) integrated: Vec<Option<f64>>,
    /// `e^{−Σᵢ Tᵢ(s, v)}` (a sun: the Gaussians from the eye towards it).
    pub(crate) c_sv: f64,
    /// Per Gaussian whose pair is integrated: the Gaussians whose attenuation the pair
    /// takes per node, at most `MAX_EXACT` — the hosts the point light sits inside
    /// (`haze_gaussians::integrated`'s, at most `MAX_HOSTS`, nearest first) but itself,
    /// then the pair's shadowers ([`haze_gaussians::integrated::shadowers`]); left out of
    /// its exponent in [`PairTerms::integrated`]. Empty elsewhere.
    pub(crate) pair_exact: Vec<Vec<usize>>,
    /// The shadowers the pairs' lists had no room for.
    pub(crate) left: LeftAtCentres,
    /// The homogeneous term's list, at most `MAX_EXACT`: the hosts and, where the
    /// homogeneous part scatters, the Gaussians that shade it
    /// ([`haze_gaussians::integrated::fog_casters`]); their `Tₖ(s, v)` is left out of
    /// `c_sv_rest` and their attenuation taken per node by `host_ratio`.
    pub(crate) exact: Vec<usize>,
    /// The Gaussians of [`PairTerms::exact`], copied for the per-ray `host_ratio`.
    pub(crate) exact_blobs: Vec<Blob>,
    /// `C_sv` without the exact list (the homogeneous term takes theirs per ray).
    pub(crate) c_sv_rest: f64,
}

/// The integrated path's terms of one light (module docs): per Gaussian the pair's
/// `e^{Eᵢ}` without the exact list where its bound exceeds `target`, the light's exact
/// list, `C_sv` and `C_sv` without the list; `g` holds the Gaussians' `Eᵢ`, `background`
/// whether a background hides the suns, `fog` whether the homogeneous part scatters.
pub(crate) fn pair_terms(
    set: &GaussianSet,
    source: Source,
    eye: Vec3,
    g: &[f64],
    background: bool,
    fog: bool,
    options: &PaperBOptions,
) -> PairTerms {
    let target = options.target;
    let max_exact = options.max_exact.min(MAX_EXACT);
    let mut hosts = hosts_of(set, source, target);
    hosts.truncate(max_exact);
    let sun_hidden = matches!(source, Source::Sun(_)) && background;
    let flagged: Vec<usize> = set
        .blobs()
        .iter()
        .enumerate()
        .filter(|(_, b)| bound(b, source) > target && !sun_hidden)
        .map(|(i, _)| i)
        .collect();
    let mut integrated = vec![None; g.len()];
    let mut pair_exact = vec![Vec::new(); g.len()];
    let lists: Vec<(usize, PairList)> = flagged
        .par_iter()
        .map(|&i| {
            let list = if target.is_finite() {
                pair_list(set, source, eye, i, &hosts, max_exact)
            } else {
                PairList::default()
            };
            (i, list)
        })
        .collect();
    let mut left = LeftAtCentres::default();
    for (i, p) in lists {
        integrated[i] = Some((g[i] + list_share(set, source, eye, i, &p.list)).exp());
        pair_exact[i] = p.list;
        left.shadows += p.left;
        left.pairs += usize::from(p.left > 0);
        left.largest = left.largest.max(p.largest_left);
    }
    // The homogeneous term's list: the hosts and the Gaussians that shade the fog.
    let mut exact = hosts.clone();
    if let Source::Point(s) = source
        && fog
        && target.is_finite()
    {
        let room = max_exact.saturating_sub(exact.len());
        exact.extend(fog_casters(set.blobs(), s, &hosts, target, room));
    }
    let (c_sv, c_sv_rest) = match source.path(eye) {
        Some((d, len)) => {
            let mut rest = 0.0;
            let all = set.depth(eye, d, len, None).0;
            for &k in &exact {
                let h = &set.blobs()[k];
                rest += line::gaussian(h.c, h.a, h.center, eye, d, len);
            }
            ((-all).exp(), (-(all - rest).max(0.0)).exp())
        }
        None => (1.0, 1.0),
    };
    PairTerms {
        integrated,
        pair_exact,
        left,
        exact_blobs: exact.iter().map(|&k| set.blobs()[k]).collect(),
        exact,
        c_sv,
        c_sv_rest,
    }
}

/// The Gaussians a point light sits inside ([`haze_gaussians::integrated::host_depth`]),
/// at most [`MAX_HOSTS`], nearest (in radii) first; none for a sun or an infinite target.
fn hosts_of(set: &GaussianSet, source: Source, target: f64) -> Vec<usize> {
    let Source::Point(s) = source else {
        return Vec::new();
    };
    if target.is_infinite() {
        return Vec::new();
    }
    let mut hosts: Vec<(f64, usize)> = set
        .blobs()
        .iter()
        .enumerate()
        .filter_map(|(i, b)| host_depth(b, s).map(|rho| (rho, i)))
        .collect();
    hosts.sort_by(|a, b| a.0.total_cmp(&b.0));
    hosts.truncate(MAX_HOSTS);
    hosts.into_iter().map(|(_, i)| i).collect()
}

/// The list of the integrated pair of Gaussian `i` and `source` (empty for a sun): the
/// hosts but `i`, then its shadowers among the Gaussians near the segments from the light
/// and the eye to its centre (the cones lie within its support's reach of them), at most
/// `max_exact` in all.
fn pair_list(
    set: &GaussianSet,
    source: Source,
    eye: Vec3,
    i: usize,
    hosts: &[usize],
    max_exact: usize,
) -> PairList {
    let Source::Point(s) = source else {
        return PairList::default();
    };
    let b = &set.blobs()[i];
    let reach = SUPPORT / b.a;
    let mut near = Vec::new();
    for o in [s, eye] {
        let u = sub(b.center, o);
        let len = norm(u);
        if len > 0.0 {
            set.near_segment(o, u.map(|c| c / len), len, reach, |j| near.push(j));
        } else {
            set.near_segment(o, [0.0, 0.0, 1.0], 0.0, reach, |j| near.push(j));
        }
    }
    near.sort_unstable();
    near.dedup();
    let mut list: Vec<usize> = hosts.iter().copied().filter(|&k| k != i).collect();
    let room = max_exact.saturating_sub(list.len());
    let found = shadowers(set.blobs(), &near, s, eye, i, hosts);
    list.extend(found.iter().take(room).map(|x| x.1));
    PairList {
        list,
        left: found.len().saturating_sub(room),
        largest_left: found.get(room).map_or(0.0, |x| x.0),
    }
}

/// One pair's list, with the shadowers it had no room for.
#[derive(Default)]
struct PairList {
    list: Vec<usize>,
    /// How many shadowers were left out.
    left: usize,
    /// The largest error among them.
    largest_left: f64,
}

/// `Σₖ Tₖ(s, bᵢ) + Tₖ(bᵢ, v)` over `list`: its share of Gaussian `i`'s exponent `Eᵢ`,
/// taken out where the pair evaluates the list per node (0 for a sun).
fn list_share(set: &GaussianSet, source: Source, eye: Vec3, i: usize, list: &[usize]) -> f64 {
    let (Source::Point(s), b) = (source, set.blobs()[i].center) else {
        return 0.0;
    };
    let (u, d) = (sub(s, b), norm(sub(s, b)));
    let (w, dw) = (sub(eye, b), norm(sub(eye, b)));
    list.iter()
        .map(|&k| {
            let h = &set.blobs()[k];
            let mut t = 0.0;
            if d > 0.0 {
                t += line::gaussian(h.c, h.a, h.center, b, u.map(|c| c / d), d);
            }
            if dw > 0.0 {
                t += line::gaussian(h.c, h.a, h.center, b, w.map(|c| c / dw), dw);
            }
            t
        })
        .sum()
}
