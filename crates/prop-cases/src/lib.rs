//! The case count of every property test in the workspace, so that `PROPTEST_CASES` lengthens
//! (or shortens) each of them: a long campaign is `PROPTEST_CASES=100000 cargo test --release
//! --workspace`, with no change to the code.
//!
//! Contract: [`config`] is proptest's own default configuration (which reads `PROPTEST_CASES`
//! and proptest's other variables); with `PROPTEST_CASES` unset, a test that runs more cases
//! than proptest's default (256) keeps its own count, as its author chose it for its input
//! space. Why not `ProptestConfig::with_cases(n)` in each test: that count wins over the
//! variable, which a campaign then cannot change.

use proptest::test_runner::Config;

/// The environment variable proptest reads for its case count.
pub const CASES_VARIABLE: &str = "PROPTEST_CASES";

/// A property test's configuration: `PROPTEST_CASES` cases where set, otherwise the larger of
/// `own_cases` and proptest's default.
pub fn config(own_cases: u32) -> Config {
    config_with(std::env::var_os(CASES_VARIABLE).is_some(), own_cases)
}

fn config_with(variable_set: bool, own_cases: u32) -> Config {
    let default = Config::default();
    if variable_set {
        default
    } else {
        Config {
            cases: own_cases.max(default.cases),
            ..default
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_higher_own_count_stays_the_default() {
        if std::env::var_os(CASES_VARIABLE).is_some() {
            // proptest's default then carries the variable; the other arm is the one tested.
            assert_eq!(config_with(true, 3000).cases, Config::default().cases);
            return;
        }
        assert_eq!(Config::default().cases, 256);
        assert_eq!(config_with(false, 3000).cases, 3000);
        assert_eq!(config_with(false, 48).cases, 256);
    }

    #[test]
    fn the_variable_wins_over_any_own_count() {
        let default = Config::default();
        assert_eq!(config_with(true, 3000).cases, default.cases);
        assert_eq!(config_with(true, 1).cases, default.cases);
    }
}
