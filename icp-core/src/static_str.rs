//! Reading back the `&'static str` fields of the error types (what a stage or parameter is
//! called, why a value is refused): a part file of a sharded run stores registrations that
//! failed with their typed error, and the merge rebuilds the same error. Each distinct text
//! is allocated once for the life of the process (the texts are the crate's own messages: a
//! small, fixed set), so reading many part files does not grow memory with their size.

use std::collections::BTreeSet;
use std::sync::Mutex;

use serde::{Deserialize, Deserializer};

/// `&'static str`, named so that serde's derive does not borrow it from the input (it would
/// then ask for input that lives forever); its fields name [`deserialize`].
pub type StaticStr = &'static str;

/// Deserializes a string as a `&'static str`, interned (see the module docs).
pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<&'static str, D::Error> {
    let text = String::deserialize(deserializer)?;
    Ok(intern(text))
}

/// The one `&'static str` equal to `text`.
fn intern(text: String) -> &'static str {
    static SEEN: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut seen = SEEN.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(&known) = seen.get(text.as_str()) {
        return known;
    }
    let leaked: &'static str = Box::leak(text.into_boxed_str());
    seen.insert(leaked);
    leaked
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::IcpError;

    #[test]
    fn errors_round_trip_and_texts_are_interned() {
        let e = IcpError::InvalidParameter {
            name: "sigma_r_const_m",
            value: 2.5,
            reason: "must be finite",
        };
        let json = serde_json::to_string(&e).unwrap();
        let back: IcpError = serde_json::from_str(&json).unwrap();
        assert_eq!(back, e);
        let a = intern("must be finite".to_owned());
        let b = intern("must be finite".to_owned());
        assert!(std::ptr::eq(a, b), "one allocation per distinct text");
    }
}
