//! Named modes registered once (a value, its name on the command line and in the reports, its
//! help): the one lookup of a mode's name, of the mode a name gives, and of the names an error
//! lists. Used by `--init` (`init`) and `--covariance` (`covariance`).

/// Registered modes: `(mode, name, help)`.
pub type Registered<T> = [(T, &'static str, &'static str)];

/// The name of `mode` in `modes`.
pub fn name_of<T: PartialEq>(modes: &Registered<T>, mode: &T) -> &'static str {
    modes
        .iter()
        .find(|m| m.0 == *mode)
        .map(|m| m.1)
        .expect("every mode is registered")
}

/// The mode of `modes` whose name `matches` `given`.
pub fn named<T: Copy>(
    modes: &Registered<T>,
    given: &str,
    matches: impl Fn(&str, &str) -> bool,
) -> Option<T> {
    modes.iter().find(|m| matches(m.1, given)).map(|m| m.0)
}

/// The registered names, for an error: "a, b, c".
pub fn names<T>(modes: &Registered<T>) -> String {
    modes.iter().map(|m| m.1).collect::<Vec<_>>().join(", ")
}
