//! Flags given to a command in a mode that does not use them (a smoke render's lights
//! beside `--scene`, a fog's beside an asset): named in one line instead of ignored.
//!
//! A flag counts as given when its value differs from clap's default, read from the
//! command's own parser, so the defaults live in one place (the `#[arg]` attributes).

use clap::{Args, FromArgMatches};
use std::fmt::Debug;

/// The arguments `T` parses from `argv` (a minimal command line of the mode), every other
/// flag at its default; `None` if clap refuses `argv`.
pub fn defaults<T: Args + FromArgMatches>(argv: &[&'static str]) -> Option<T> {
    let matches = T::augment_args(clap::Command::new(argv[0]))
        .try_get_matches_from(argv)
        .ok()?;
    T::from_arg_matches(&matches).ok()
}

/// Whether a flag's value differs from its default (compared as printed: the values are
/// plain numbers, strings, vectors and enums).
pub fn differs(value: &dyn Debug, default: &dyn Debug) -> bool {
    format!("{value:?}") != format!("{default:?}")
}

/// The names of the flags marked given.
pub fn given(flags: &[(&'static str, bool)]) -> Vec<&'static str> {
    flags.iter().filter(|f| f.1).map(|f| f.0).collect()
}

/// "--a, --b apply" / "--a applies".
pub fn apply(names: &[&str]) -> String {
    let verb = if names.len() == 1 { "applies" } else { "apply" };
    format!("{} {verb}", names.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, clap::Args)]
    struct Probe {
        #[arg(long, default_value_t = 4.0)]
        sigma: f64,
        #[arg(long)]
        name: Option<String>,
    }

    #[test]
    fn a_flag_is_given_when_it_differs_from_claps_default() {
        let d: Probe = defaults(&["probe"]).unwrap();
        let given_at = |s: f64, n: Option<&str>| {
            given(&[
                ("--sigma", differs(&s, &d.sigma)),
                ("--name", differs(&n.map(String::from), &d.name)),
            ])
        };
        assert!(given_at(4.0, None).is_empty());
        assert_eq!(given_at(3.0, None), ["--sigma"]);
        assert_eq!(given_at(4.0, Some("x")), ["--name"]);
        assert!(defaults::<Probe>(&["probe", "--unknown"]).is_none());
        assert_eq!(apply(&["--a"]), "--a applies");
        assert_eq!(apply(&["--a", "--b"]), "--a, --b apply");
    }
}
