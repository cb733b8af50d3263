//! The config reference is generated from the specs' JSON schemas: every key of
//! `[compose.environment]` and `[compose.camera]` carries a description with its default.

use camsim_compose::camera::CameraSamplerSpec;
use camsim_compose::environment::EnvironmentSpec;

fn check(schema: schemars::Schema, what: &str) {
    let v = schema.as_value();
    let props = v
        .get("properties")
        .and_then(|p| p.as_object())
        .unwrap_or_else(|| panic!("{what}: no properties"));
    assert!(props.len() >= 10, "{what}: {} keys", props.len());
    for (k, p) in props {
        let d = p.get("description").and_then(|d| d.as_str()).unwrap_or("");
        assert!(
            d.to_lowercase().contains("default"),
            "{what}.{k}: description {d:?} states no default"
        );
    }
    assert_eq!(
        v.get("additionalProperties").and_then(|a| a.as_bool()),
        Some(false),
        "{what}: unknown keys must be refused"
    );
}

#[test]
fn every_key_is_documented_with_its_default() {
    check(
        schemars::schema_for!(EnvironmentSpec),
        "compose.environment",
    );
    check(schemars::schema_for!(CameraSamplerSpec), "compose.camera");
}
