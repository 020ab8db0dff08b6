//! A table as text, for the matrix's terminal table and every study's: aligned for the
//! terminal, and Markdown for the studies' write-up (`docs/studies/`).

use std::collections::BTreeMap;

/// Rows of printed cells under a header. The numbers behind the cells go to CSV and JSON
/// from each study's typed rows; this is only how they print.
#[derive(Clone, Debug, Default)]
pub struct Table {
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// Rows a failed run made, by index, each with the index of its error cell: the
    /// terminal lets the error run on from there rather than widen its column.
    failed: BTreeMap<usize, usize>,
    /// Text after a row's cells, by row: why a row whose figures stand failed.
    tails: BTreeMap<usize, String>,
    /// The leading columns aligned left (names); the rest, numbers, right. At least 1.
    left: usize,
    /// Lines printed under the table: sources, conventions, caveats.
    pub notes: Vec<String>,
}

impl Table {
    pub fn new(title: &str, columns: &[&str]) -> Self {
        Self {
            title: title.to_string(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            left: 1,
            ..Default::default()
        }
    }

    /// The same table with its first `n` columns aligned left.
    pub fn left_aligned(mut self, n: usize) -> Self {
        self.left = n.max(1);
        self
    }

    pub fn row(&mut self, cells: Vec<String>) {
        debug_assert_eq!(cells.len(), self.columns.len(), "one cell per column");
        self.rows.push(cells);
    }

    /// A row whose figures stand, then `tail` after them (why the run failed anyway).
    pub fn row_then(&mut self, cells: Vec<String>, tail: String) {
        self.tails.insert(self.rows.len(), tail);
        self.row(cells);
    }

    /// A row for a run that failed: the cells that name it, then the error, then blanks.
    pub fn failed_row(&mut self, names: Vec<String>, error: &str) {
        self.verdict_row(names, format!("FAILED: {error}"));
    }

    /// A row for a run that did not give its figures: the cells that name it, then
    /// `verdict` (the error, as it is), then blanks.
    pub fn verdict_row(&mut self, names: Vec<String>, verdict: String) {
        self.failed.insert(self.rows.len(), names.len());
        let blanks = self.columns.len().saturating_sub(names.len() + 1);
        let cells = names
            .into_iter()
            .chain([verdict])
            .chain(std::iter::repeat_n(String::new(), blanks))
            .collect();
        self.row(cells);
    }

    fn widths(&self) -> Vec<usize> {
        self.columns
            .iter()
            .enumerate()
            .map(|(i, c)| {
                self.rows
                    .iter()
                    .enumerate()
                    .filter(|&(r, _)| self.failed.get(&r).is_none_or(|&e| i < e))
                    .map(|(_, row)| row[i].chars().count())
                    .chain([c.chars().count()])
                    .max()
                    .unwrap_or(0)
            })
            .collect()
    }

    /// Aligned columns: text left, numbers right.
    pub fn terminal(&self) -> String {
        let widths = self.widths();
        let line = |cells: &[String]| {
            cells
                .iter()
                .zip(&widths)
                .enumerate()
                .map(|(i, (c, &w))| {
                    if i < self.left {
                        format!("{c:<w$}")
                    } else {
                        format!("{c:>w$}")
                    }
                })
                .collect::<Vec<_>>()
                .join("  ")
                .trim_end()
                .to_string()
        };
        let mut out = format!("{}\n\n{}\n", self.title, line(&self.columns));
        let rule: Vec<String> = widths.iter().map(|&w| "-".repeat(w)).collect();
        out += &line(&rule);
        out.push('\n');
        for (i, r) in self.rows.iter().enumerate() {
            match self.failed.get(&i).copied() {
                // The naming cells aligned, then the error as it is.
                Some(e) => {
                    let names = line(&r[..e]);
                    let pad = widths[..e].iter().sum::<usize>() + 2 * e;
                    out += &format!("{names:<pad$}{}", r[e]);
                }
                None => out += &line(r),
            }
            if let Some(tail) = self.tails.get(&i) {
                out += &format!("  {tail}");
            }
            out.push('\n');
        }
        for n in &self.notes {
            out += &format!("\n{n}");
        }
        if !self.notes.is_empty() {
            out.push('\n');
        }
        out
    }

    /// A Markdown table (names left, the rest right-aligned) and its notes.
    pub fn markdown(&self) -> String {
        let mut out = format!("**{}**\n\n| {} |\n|", self.title, self.columns.join(" | "));
        for i in 0..self.columns.len() {
            out += if i < self.left { " --- |" } else { " ---: |" };
        }
        out.push('\n');
        for r in &self.rows {
            out += &format!("| {} |\n", r.join(" | "));
        }
        for n in &self.notes {
            out += &format!("\n{n}\n");
        }
        out
    }
}

/// `x` with `digits` significant digits, in plain or scientific notation by size.
/// A share as a percentage with one decimal; "-" where there is none (0 of 0).
pub fn percent(share: Option<f64>) -> String {
    share.map_or("-".into(), |s| format!("{:.1}%", 100.0 * s))
}

pub fn sig(x: f64, digits: usize) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    if (-3..5).contains(&magnitude) {
        let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits.saturating_sub(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(sig(0.0021842, 3), "0.00218");
        assert_eq!(sig(0.946, 3), "0.946");
        assert_eq!(sig(12.345, 3), "12.3");
        assert_eq!(sig(6.0e-8, 2), "6.0e-8");
        assert_eq!(sig(123456.0, 3), "1.23e5");
        assert_eq!(sig(0.0, 3), "0");
    }

    #[test]
    fn tables_align_and_render_markdown() {
        let mut t = Table::new("T", &["name", "value"]);
        t.row(vec!["a".into(), "1.5".into()]);
        t.row(vec!["longer".into(), "10".into()]);
        t.notes.push("note".into());
        let text = t.terminal();
        assert!(text.contains("\na         1.5\n"), "{text}");
        assert!(text.contains("\nlonger     10\n"), "{text}");
        let md = t.markdown();
        assert!(
            md.contains("| name | value |\n| --- | ---: |\n| a | 1.5 |"),
            "{md}"
        );
        assert!(md.ends_with("\nnote\n"));
    }

    #[test]
    fn a_failed_row_keeps_the_columns_and_shows_its_whole_error() {
        let mut t = Table::new("T", &["name", "grid", "value", "more"]);
        t.row(vec!["a".into(), "2x2".into(), "1.5".into(), "7".into()]);
        let error = "a long error that names what would be valid";
        t.failed_row(vec!["bb".into(), "4x4".into()], error);
        let text = t.terminal();
        // The columns are as wide as the ok row and the headers make them.
        assert!(text.contains("\nname  grid  value  more\n"), "{text}");
        assert!(text.contains("\na      2x2    1.5     7\n"), "{text}");
        let failed = format!("\nbb     4x4  FAILED: {error}\n");
        assert!(text.contains(&failed), "{text}");
        // Markdown keeps one cell per column.
        let md = t.markdown();
        assert!(
            md.contains(&format!("| bb | 4x4 | FAILED: {error} |  |")),
            "{md}"
        );
    }
}
