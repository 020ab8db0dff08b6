//! `clusterlab explain`: the variant schema as text, with each field's meaning, allowed
//! values and default. Everything comes from the JSON schema that `schemars` derives from
//! the doc comments of `variant::schema`, so the explanation cannot drift from the code.

use std::fmt::Write;

use serde_json::{Map, Value};

/// The JSON schema of a variant file.
pub fn schema() -> Value {
    crate::variant::schema()
}

/// The whole schema, explained.
pub fn explain() -> String {
    let schema = schema();
    let defs = schema["$defs"].as_object().cloned().unwrap_or_default();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "A variant file is RON: one parenthesised struct with the fields below. Every field may\n\
         be left out and then takes the default shown after `=`. Optional sections are written\n\
         without `Some`: `post: (bloom: (radius: 6))`.\n\n\
         A minimal variant:\n\n    (\n        description: \"Forward+ on the default grid\",\n        pipeline: ClusteredForward,\n    )\n"
    );
    explain_struct(&schema, "", &defs, &mut out);
    out
}

fn explain_struct(def: &Value, prefix: &str, defs: &Map<String, Value>, out: &mut String) {
    let Some(props) = def["properties"].as_object() else {
        return;
    };
    let indent = "    ".repeat(prefix.matches('.').count());
    for (name, prop) in props {
        let path = format!("{prefix}{name}");
        let default = prop.get("default").map_or("required".to_string(), |d| {
            if d.is_null() {
                "left out".into()
            } else {
                ron_text(d, prop, defs)
            }
        });
        let _ = writeln!(out, "{indent}{path}: {} = {default}", type_name(prop));
        if let Some(doc) = prop["description"].as_str() {
            write_doc(out, &format!("{indent}    "), doc);
        }
        let target = resolve(prop, defs);
        if let Some(variants) = target.and_then(|t| t["oneOf"].as_array()) {
            explain_variants(variants, &format!("{indent}    "), defs, out);
        }
        let _ = writeln!(out);
        if let Some(t) = target
            && t["properties"].is_object()
        {
            explain_struct(t, &format!("{path}."), defs, out);
        }
    }
}

fn explain_variants(variants: &[Value], indent: &str, defs: &Map<String, Value>, out: &mut String) {
    let _ = writeln!(out, "{indent}one of:");
    for v in variants {
        if let Some(name) = v["const"].as_str() {
            let _ = writeln!(out, "{indent}  {name}");
        } else if let Some((name, body)) = v["properties"].as_object().and_then(|p| p.iter().next())
        {
            // A variant that wraps a struct (`Sampled(Sampling)`) shows the struct's fields.
            let body = resolve(body, defs).unwrap_or(body);
            let fields: Vec<String> = body["properties"]
                .as_object()
                .map(|f| {
                    f.iter()
                        .map(|(k, t)| format!("{k}: {}", type_name(t)))
                        .collect()
                })
                .unwrap_or_default();
            let _ = writeln!(out, "{indent}  {name}({})", fields.join(", "));
            if let Some(doc) = v["description"].as_str() {
                write_doc(out, &format!("{indent}      "), doc);
            }
            for (k, t) in body["properties"].as_object().into_iter().flatten() {
                if let Some(doc) = t["description"].as_str() {
                    write_doc(out, &format!("{indent}      {k}: "), doc);
                }
                let inner = resolve(t, defs);
                if let Some(variants) = inner.and_then(|d| d["oneOf"].as_array()) {
                    explain_variants(variants, &format!("{indent}        "), defs, out);
                }
                // A field that is a struct of its own (`spatial: SpatialReuse`): its fields.
                for (f, ft) in inner
                    .and_then(|d| d["properties"].as_object())
                    .into_iter()
                    .flatten()
                {
                    if let Some(doc) = ft["description"].as_str() {
                        write_doc(out, &format!("{indent}        {k}.{f}: "), doc);
                    }
                }
            }
            continue;
        }
        if let Some(doc) = v["description"].as_str() {
            write_doc(out, &format!("{indent}      "), doc);
        }
    }
}

/// The definition a property refers to (through `$ref`, or an optional's `anyOf`).
fn resolve<'a>(prop: &'a Value, defs: &'a Map<String, Value>) -> Option<&'a Value> {
    if let Some(r) = prop["$ref"].as_str() {
        return defs.get(r.trim_start_matches("#/$defs/"));
    }
    prop["anyOf"]
        .as_array()?
        .iter()
        .find_map(|alt| alt["$ref"].as_str())
        .and_then(|r| defs.get(r.trim_start_matches("#/$defs/")))
}

fn type_name(prop: &Value) -> String {
    if let Some(r) = prop["$ref"].as_str() {
        return r.trim_start_matches("#/$defs/").to_string();
    }
    if let Some(alts) = prop["anyOf"].as_array() {
        let inner: Vec<String> = alts
            .iter()
            .filter(|a| a["type"] != "null")
            .map(type_name)
            .collect();
        return format!("optional {}", inner.join(" | "));
    }
    // A plain optional: `"type": ["boolean", "null"]`.
    if let Some(types) = prop["type"].as_array() {
        let inner: Vec<String> = types
            .iter()
            .filter(|t| *t != "null")
            .map(|t| type_name(&serde_json::json!({ "type": t, "format": prop["format"] })))
            .collect();
        return format!("optional {}", inner.join(" | "));
    }
    match (prop["type"].as_str(), prop["format"].as_str()) {
        (Some("boolean"), _) => "bool".into(),
        (Some("string"), _) => "string".into(),
        (Some("integer"), Some("uint32")) => "u32".into(),
        (Some("number"), Some("float")) => "f32".into(),
        (Some("array"), _) => {
            let items: Vec<String> = prop["prefixItems"]
                .as_array()
                .map(|a| a.iter().map(type_name).collect())
                .unwrap_or_default();
            format!("({})", items.join(", "))
        }
        (Some(t), _) => t.to_string(),
        (None, _) => "value".into(),
    }
}

/// A default value written as it would be in a variant file.
fn ron_text(value: &Value, prop: &Value, defs: &Map<String, Value>) -> String {
    match value {
        Value::Null => "None".into(),
        Value::Bool(b) => b.to_string(),
        // Defaults are f32 in the schema; print them as f32 so 0.02 is not 0.0199999...
        Value::Number(n) if n.is_f64() => format!("{:?}", n.as_f64().unwrap_or(0.0) as f32),
        Value::Number(n) => n.to_string(),
        Value::String(s) if prop["type"] == "string" => format!("{s:?}"),
        Value::String(s) => s.clone(),
        Value::Array(items) => {
            let parts: Vec<String> = items
                .iter()
                .map(|i| ron_text(i, &Value::Null, defs))
                .collect();
            format!("({})", parts.join(", "))
        }
        Value::Object(fields) => {
            let target = resolve(prop, defs);
            let is_enum = target.is_some_and(|t| t["oneOf"].is_array());
            if is_enum && fields.len() == 1 {
                let (name, inner) = fields.iter().next().expect("one field");
                return format!("{name}{}", ron_text(inner, &Value::Null, defs));
            }
            let parts: Vec<String> = fields
                .iter()
                .map(|(k, v)| {
                    let sub = target
                        .and_then(|t| t["properties"].get(k))
                        .unwrap_or(&Value::Null);
                    format!("{k}: {}", ron_text(v, sub, defs))
                })
                .collect();
            format!("({})", parts.join(", "))
        }
    }
}

fn write_doc(out: &mut String, indent: &str, doc: &str) {
    // Rejoin the doc comment's hard-wrapped lines into one paragraph per blank-line block.
    let text = doc
        .split("\n\n")
        .map(|p| p.replace('\n', " "))
        .collect::<Vec<_>>();
    let pad = " ".repeat(indent.chars().count());
    for (i, paragraph) in text.iter().enumerate() {
        let first = if i == 0 { indent } else { pad.as_str() };
        let _ = writeln!(out, "{first}{paragraph}");
    }
}
