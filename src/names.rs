//! The nearest known names to one that is not known, for "did you mean" in errors about
//! variants, scenes and cases.

/// Up to three of `known` nearest to `name`, nearest first: those within an edit distance
/// of a third of the longer name (at least 2), and those that contain it or that it
/// contains.
pub fn nearest<'a>(name: &str, known: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let mut close: Vec<(usize, &str)> = known
        .into_iter()
        .filter_map(|k| {
            let distance = strsim::levenshtein(name, k);
            let reach = (name.len().max(k.len()) / 3).max(2);
            let contained = !name.is_empty() && (k.contains(name) || name.contains(k));
            (distance <= reach || contained).then_some((distance, k))
        })
        .collect();
    close.sort();
    close.dedup();
    close.into_iter().take(3).map(|(_, k)| k).collect()
}

/// "; nearest: `a`, `b`" for the names [`nearest`] finds, or nothing.
pub fn did_you_mean<'a>(name: &str, known: impl IntoIterator<Item = &'a str>) -> String {
    let near = nearest(name, known);
    if near.is_empty() {
        String::new()
    } else {
        let quoted: Vec<String> = near.iter().map(|n| format!("`{n}`")).collect();
        format!("; nearest: {}", quoted.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_typo_finds_the_name_and_a_stranger_finds_none() {
        let known = [
            "forward_plus",
            "forward_plus_bvh",
            "naive_forward",
            "atrium",
        ];
        assert_eq!(nearest("forward_plu", known)[0], "forward_plus");
        assert_eq!(nearest("atrum", known), ["atrium"]);
        assert!(nearest("zzzzzzzz", known).is_empty());
        assert_eq!(did_you_mean("zzzzzzzz", known), "");
    }
}
