//! The text of an insta snapshot file: a header of its source, description and expression,
//! then the contents.

/// A snapshot file's text as insta writes it: its header, then the contents.
pub(super) fn insta_text(
    source: &str,
    description: &str,
    expression: &str,
    contents: &str,
) -> String {
    format!(
        "---\nsource: {source}\ndescription: \"{description}\"\nexpression: {expression}\n---\n{contents}\n"
    )
}

/// The contents of a snapshot file's text: what follows its header.
pub(super) fn contents(text: &str) -> Option<&str> {
    let rest = text.strip_prefix("---\n")?;
    let end = rest.find("\n---\n")?;
    Some(&rest[end + "\n---\n".len()..])
}
