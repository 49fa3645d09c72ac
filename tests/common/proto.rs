//! Validators for the documents in `proto/`, resolving their cross-document `$ref`s
//! (`https://texatlas.dev/proto/<file>`) from the checkout, offline.
use std::path::Path;

/// `proto/<name>` parsed.
pub fn schema_json(name: &str) -> serde_json::Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("proto")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("schema is JSON")
}

/// Serves `https://texatlas.dev/proto/<file>` from `proto/`, and nothing else.
pub struct ProtoRetriever;

impl jsonschema::Retrieve for ProtoRetriever {
    fn retrieve(
        &self,
        uri: &jsonschema::Uri<String>,
    ) -> Result<serde_json::Value, Box<dyn std::error::Error + Send + Sync>> {
        let name = uri
            .as_str()
            .strip_prefix("https://texatlas.dev/proto/")
            .filter(|n| !n.contains('/') && !n.contains(".."))
            .ok_or_else(|| format!("{uri} is not a proto/ document"))?;
        Ok(schema_json(name))
    }
}

/// A validator for `proto/<name>`.
pub fn validator(name: &str) -> jsonschema::Validator {
    jsonschema::options()
        .with_retriever(ProtoRetriever)
        .build(&schema_json(name))
        .expect("schema compiles")
}

/// Every violation of `proto/<name>` by `instance`, with its location.
pub fn violations(name: &str, instance: &serde_json::Value) -> Vec<String> {
    validator(name)
        .iter_errors(instance)
        .map(|e| format!("{e} at {}", e.instance_path()))
        .collect()
}
