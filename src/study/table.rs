//! A study's table as text: aligned for the terminal, and Markdown for README.

/// Rows of printed cells under a header. The numbers behind the cells go to CSV and JSON
/// from each study's typed rows; this is only how they print.
#[derive(Clone, Debug, Default)]
pub struct Table {
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// Lines printed under the table: sources, conventions, caveats.
    pub notes: Vec<String>,
}

impl Table {
    pub fn new(title: &str, columns: &[&str]) -> Self {
        Self {
            title: title.to_string(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            ..Default::default()
        }
    }

    pub fn row(&mut self, cells: Vec<String>) {
        debug_assert_eq!(cells.len(), self.columns.len(), "one cell per column");
        self.rows.push(cells);
    }

    /// A row for a run that failed: the cells that name it, then the error, then blanks.
    pub fn failed_row(&mut self, names: Vec<String>, error: &str) {
        let blanks = self.columns.len().saturating_sub(names.len() + 1);
        let cells = names
            .into_iter()
            .chain([format!("FAILED: {error}")])
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
                    .map(|r| r[i].chars().count())
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
                    if i == 0 {
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
        for r in &self.rows {
            out += &line(r);
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

    /// A Markdown table (first column left, the rest right-aligned) and its notes.
    pub fn markdown(&self) -> String {
        let mut out = format!("**{}**\n\n| {} |\n|", self.title, self.columns.join(" | "));
        for i in 0..self.columns.len() {
            out += if i == 0 { " --- |" } else { " ---: |" };
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
}
