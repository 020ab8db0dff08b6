//! What a results file may hold: `merge` and `--baseline` compute with every figure in it, so
//! a figure a run could not have written (a negative or non-finite time, more useful light
//! evaluations than evaluations, an image outside the folder's `images/`) is refused, naming
//! the file's cell and field, before anything is computed or copied.

use std::path::{Component, Path};

use super::{CellRecord, Results};

/// Most milliseconds a figure may hold: about 11 days, far past any cell's time limit.
const MAX_MS: f64 = 1e9;

impl Results {
    /// Read `results.json` (a file, or a folder holding one), and check every figure in it
    /// (`merge` and `--baseline` compute with them).
    pub fn load(path: &Path) -> Result<Self, String> {
        let file = if path.is_dir() {
            path.join("results.json")
        } else {
            path.to_path_buf()
        };
        let text = crate::files::read_text(&file, crate::files::read::RESULTS).map_err(|e| {
            if e.missing {
                format!(
                    "{}: no such results file (give a matrix output folder or its results.json)",
                    path.display()
                )
            } else {
                e.to_string()
            }
        })?;
        let results: Results = serde_json::from_str(&text).map_err(|e| {
            format!(
                "{}:{}:{}: not a clusterlab results file: {e}",
                file.display(),
                e.line(),
                e.column()
            )
        })?;
        results
            .check()
            .map_err(|e| format!("{}: {e}", file.display()))?;
        Ok(results)
    }

    /// Check the figures of every cell, and that the file says which run made it.
    pub fn check(&self) -> Result<(), String> {
        if self.provenance.is_empty() {
            return Err(
                "it has no provenance (the run, adapter and variant files that made it): not a file a matrix run wrote".into(),
            );
        }
        if self.cells.is_empty() {
            return Err(
                "it holds no cells: a run that planned no cells wrote nothing to merge or compare"
                    .into(),
            );
        }
        let mut ids = std::collections::HashSet::new();
        for cell in &self.cells {
            if !ids.insert(cell.spec.id.as_str()) {
                return Err(format!("cell `{}` appears twice", cell.spec.id));
            }
            check_cell(cell)
                .and_then(|()| {
                    if cell.run < self.provenance.len() {
                        Ok(())
                    } else {
                        Err(format!(
                            "`run` is {}, but the file records {} runs in `provenance`",
                            cell.run,
                            self.provenance.len()
                        ))
                    }
                })
                .map_err(|e| format!("cell `{}`: {e}", cell.spec.id))?;
        }
        Ok(())
    }
}

/// A cell that passed has the figures a passing cell has: a shaded frame (not a debug view)
/// has its error figures, no NaN pixels, and an exact variant's frame (or a sequence marked
/// exact) is within 1 LSB. Pass or fail is derived from the figures, never taken as written.
fn check_verdict(c: &CellRecord) -> Result<(), String> {
    let lsb = crate::run::EXACT_LSB;
    if let Some(s) = &c.sequence_summary
        && s.exact
        && s.max_abs_8bit > lsb
    {
        return Err(format!(
            "`sequence_summary.exact` is true at {} LSB: an exact sequence is within {lsb} LSB",
            s.max_abs_8bit
        ));
    }
    if !c.ok() {
        return Ok(());
    }
    let Some(e) = &c.error else {
        if c.spec.debug_view {
            return Ok(());
        }
        return Err("it passed (no `failure`) without `error` figures: a shaded frame is measured against the reference".into());
    };
    if e.nan_pixels > 0 {
        return Err(format!(
            "it passed (no `failure`) with {} NaN pixels (`error.nan_pixels`): a frame with NaN pixels fails",
            e.nan_pixels
        ));
    }
    if c.exact_claim && e.max_abs_8bit > lsb {
        return Err(format!(
            "it passed (no `failure`) at {} LSB (`error.max_abs_8bit`), but its variant claims to be exact (`exact_claim`): within {lsb} LSB",
            e.max_abs_8bit
        ));
    }
    Ok(())
}

/// Each interval is [lo, hi] in milliseconds at a level between `measure::LEVEL` and 1,
/// and holds its median.
fn check_intervals(c: &CellRecord) -> Result<(), String> {
    if c.gpu_ms_interval.is_empty() {
        return Ok(());
    }
    let level = c.interval_level.unwrap_or(f64::NAN);
    if !(crate::measure::LEVEL..=1.0).contains(&level) {
        return Err(format!(
            "`interval_level` is {level}: an interval's level is in {}..=1",
            crate::measure::LEVEL
        ));
    }
    for (name, v) in &c.gpu_ms_interval {
        let field = format!("gpu_ms_interval.{name}");
        let pair = v.as_array().filter(|a| a.len() == 2);
        let Some([lo, hi]) = pair.map(|a| [a[0].as_f64(), a[1].as_f64()]) else {
            return Err(format!(
                "`{field}` is {v}: an interval is [lo, hi] in milliseconds"
            ));
        };
        let (lo, hi) = (time(&field, lo)?, time(&field, hi)?);
        let median = c.gpu_ms.get(name).and_then(serde_json::Value::as_f64);
        if lo > hi || median.is_some_and(|m| !(lo <= m && m <= hi)) {
            return Err(format!(
                "`{field}` is [{lo}, {hi}]: an interval has lo <= hi and holds its median ({})",
                median.map_or("none".into(), |m| m.to_string())
            ));
        }
    }
    Ok(())
}

/// A distance from perfect culling is its bound over its frame: a ratio above 1 is flagged
/// (within the frame's noise, or a bound above its frame), and never both.
fn check_efficiency(
    e: &crate::efficiency::Efficiency,
    frame_ms: Option<f64>,
) -> Result<(), String> {
    if e.within_noise && e.bound_above_frame {
        return Err("`efficiency` is both `within_noise` and `bound_above_frame`: a bound past its frame is one or the other".into());
    }
    if e.efficiency > 1.0 && !(e.within_noise || e.bound_above_frame) {
        return Err(format!(
            "`efficiency.efficiency` is {}: a bound above its frame is flagged `within_noise` (inside the frame's interval) or `bound_above_frame`, never a plain ratio above 1",
            e.efficiency
        ));
    }
    if e.bound_above_frame && e.efficiency <= 1.0 {
        return Err(format!(
            "`efficiency.bound_above_frame` is set, but `efficiency.efficiency` is {}: the bound is not above its frame",
            e.efficiency
        ));
    }
    if let Some(frame) = frame_ms.filter(|&f| f > 0.0) {
        // Rounded figures: the bound and the frame to 0.0005 ms each, the ratio to 0.00005.
        let ratio = e.bound_ms / frame;
        let slack = ratio * (0.0005 / e.bound_ms.max(1e-3) + 0.0005 / frame) + 0.00005;
        if (e.efficiency - ratio).abs() > slack + 1e-12 {
            return Err(format!(
                "`efficiency.efficiency` is {}, but `efficiency.bound_ms` over `gpu_ms.total` is {} / {frame} = {ratio:.4}",
                e.efficiency, e.bound_ms
            ));
        }
    }
    Ok(())
}

fn check_cell(c: &CellRecord) -> Result<(), String> {
    let p = &c.spec.params;
    if p.width == 0 || p.height == 0 {
        return Err(format!(
            "`params` size {}x{} has no pixels",
            p.width, p.height
        ));
    }
    for (name, v) in &c.gpu_ms {
        time(&format!("gpu_ms.{name}"), v.as_f64())?;
    }
    for (name, v) in &c.gpu_ms_spread {
        let pair = v.as_array().filter(|a| a.len() == 2);
        let field = format!("gpu_ms_spread.{name}");
        let Some([lo, hi]) = pair.map(|a| [a[0].as_f64(), a[1].as_f64()]) else {
            return Err(format!(
                "`{field}` is {v}: a spread is [min, max] in milliseconds"
            ));
        };
        let (lo, hi) = (time(&field, lo)?, time(&field, hi)?);
        if lo > hi {
            return Err(format!(
                "`{field}` is [{lo}, {hi}]: its min is above its max"
            ));
        }
    }
    for (field, v) in [("wall_ms", c.wall_ms), ("reference_ms", c.reference_ms)] {
        if let Some(v) = v {
            time(field, Some(v))?;
        }
    }
    if c.refused && c.ok() {
        return Err("it is `refused` but has no `failure` saying why".into());
    }
    if c.ok() {
        if !c.gpu_ms.contains_key("total") {
            return Err("it ran (no `failure`) but has no `gpu_ms.total`".into());
        }
        if c.frames == 0 {
            return Err("it ran (no `failure`) but timed 0 `frames`".into());
        }
    }
    check_intervals(c)?;
    check_verdict(c)?;
    if let Some(s) = c.speedup_vs_naive
        && !(s.is_finite() && s > 0.0)
    {
        return Err(format!(
            "`speedup_vs_naive` is {s}: a ratio of times is finite and above 0"
        ));
    }
    let pixels = p.width as u64 * p.height as u64;
    if let Some(e) = &c.error {
        if e.max_abs_8bit > 255 {
            return Err(format!(
                "`error.max_abs_8bit` is {}: 8-bit differences are 0 to 255",
                e.max_abs_8bit
            ));
        }
        for (field, v, max) in [
            ("error.rmse", e.rmse, f64::MAX),
            ("error.rmse_8bit", e.rmse_8bit, 255.0),
            ("error.max_abs_hdr", e.max_abs_hdr, f64::MAX),
            ("error.flip_mean", e.flip_mean, 1.0),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(format!(
                    "`{field}` is {v}: it is a finite figure in 0..={max}"
                ));
            }
        }
        // The smallest mean square error of two 8-bit images that differ is one step in one
        // of the 3 x pixels channels: 1 / (3 pixels), so PSNR = 10 log10(255^2 / MSE) is at
        // most 10 log10(255^2 x 3 pixels); the largest, 255 in every channel, gives 0.
        let max_psnr = 10.0 * (255.0f64 * 255.0 * 3.0 * pixels as f64).log10();
        if let Some(psnr) = e.psnr_db
            && !(psnr.is_finite() && (0.0..=max_psnr).contains(&psnr))
        {
            let psnr = if psnr.abs() < 1e6 {
                psnr.to_string()
            } else {
                format!("{psnr:e}")
            };
            return Err(format!(
                "`error.psnr_db` is {psnr}: the PSNR of two {pixels}-pixel 8-bit images that differ is in 0..={max_psnr:.2} dB (null when they are identical)"
            ));
        }
        if !(e.relative_mse.is_finite() && e.relative_mse >= 0.0) {
            return Err(format!(
                "`error.relative_mse` is {}: a mean of squares is finite and 0 or more",
                e.relative_mse
            ));
        }
        // A root mean square is at most the largest of its terms.
        if e.rmse_8bit > e.max_abs_8bit as f64 {
            return Err(format!(
                "`error.rmse_8bit` is {}, more than `error.max_abs_8bit` ({}): a root mean square is at most its largest term",
                e.rmse_8bit, e.max_abs_8bit
            ));
        }
        for (field, n) in [
            ("error.pixels_over_1lsb", e.pixels_over_1lsb),
            ("error.nan_pixels", e.nan_pixels),
        ] {
            if n > pixels {
                return Err(format!(
                    "`{field}` is {n}, more than the cell's {pixels} pixels"
                ));
            }
        }
    }
    if let Some(s) = &c.stats {
        if s.useful_light_evals > s.light_evals {
            return Err(format!(
                "`stats.useful_light_evals` is {}, more than the {} light evaluations performed",
                s.useful_light_evals, s.light_evals
            ));
        }
        if s.active_clusters > s.clusters || s.assigned_clusters > s.clusters {
            return Err(format!(
                "`stats` has {} active and {} assigned clusters of {}",
                s.active_clusters, s.assigned_clusters, s.clusters
            ));
        }
        if !(s.edge_fraction.is_finite() && (0.0..=1.0).contains(&s.edge_fraction)) {
            return Err(format!(
                "`stats.edge_fraction` is {}: a fraction of the pixels is in 0..=1",
                s.edge_fraction
            ));
        }
        let mean = s.mean_lights_per_visible_cluster;
        if !(mean.is_finite() && mean >= 0.0) {
            return Err(format!(
                "`stats.mean_lights_per_visible_cluster` is {mean}: it is finite and 0 or more"
            ));
        }
        if let Some([near, far]) = s.z_range
            && !(near.is_finite() && far.is_finite() && 0.0 < near && near <= far)
        {
            return Err(format!(
                "`stats.z_range` is [{near}, {far}]: a depth range has 0 < near <= far"
            ));
        }
    }
    if let Some(e) = &c.efficiency {
        for (field, v) in [
            (
                "efficiency.frame_without_lights_ms",
                e.frame_without_lights_ms,
            ),
            ("efficiency.bound_ms", e.bound_ms),
        ] {
            time(field, Some(v))?;
        }
        for (field, v) in [
            ("efficiency.ns_per_evaluation", e.ns_per_evaluation),
            (
                "efficiency.ns_per_useful_evaluation",
                e.ns_per_useful_evaluation,
            ),
            ("efficiency.efficiency", e.efficiency),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("`{field}` is {v}: it is finite and 0 or more"));
            }
        }
        check_efficiency(e, c.total_ms())?;
    }
    for (field, path) in [
        ("images.image", &c.images.image),
        ("images.heat", &c.images.heat),
        ("images.debug", &c.images.debug),
    ] {
        if let Some(path) = path {
            image_path(path).map_err(|why| format!("`{field}` is `{path}`: {why}"))?;
        }
    }
    if let Some(s) = &c.sequence_summary {
        time("sequence_summary.first_ms", Some(s.first_ms))?;
        time("sequence_summary.frame_ms", Some(s.frame_ms))?;
        for (i, &ms) in s.totals_ms.iter().enumerate() {
            time(&format!("sequence_summary.totals_ms[{i}]"), Some(ms))?;
        }
        if s.frames == 0 || s.totals_ms.len() != s.frames as usize {
            return Err(format!(
                "`sequence_summary` has {} frames and {} frame times: a sequence has one time per frame, and a frame at least",
                s.frames,
                s.totals_ms.len()
            ));
        }
        let [lo, hi] = s.frame_ms_spread;
        let (lo, hi) = (
            time("sequence_summary.frame_ms_spread", Some(lo))?,
            time("sequence_summary.frame_ms_spread", Some(hi))?,
        );
        if lo > hi {
            return Err(format!(
                "`sequence_summary.frame_ms_spread` is [{lo}, {hi}]: its min is above its max"
            ));
        }
        for (name, v) in &s.pass_ms {
            time(&format!("sequence_summary.pass_ms.{name}"), v.as_f64())?;
        }
        // The first frame is always checked and never reused.
        for (field, n, most) in [
            ("checked_frames", s.checked_frames, s.frames),
            ("frames_reused", s.frames_reused, s.frames - 1),
            ("patch_rebuilds", s.patch_rebuilds, s.frames - 1),
        ] {
            if n > most {
                return Err(format!(
                    "`sequence_summary.{field}` is {n}, more than the {most} a sequence of {} frames can have",
                    s.frames
                ));
            }
        }
        if s.checked_frames == 0 {
            return Err("`sequence_summary.checked_frames` is 0: a sequence checks its first and last frames".into());
        }
        if !(0.0..=1.0).contains(&s.moving) {
            return Err(format!(
                "`sequence_summary.moving` is {}: a fraction of the lights is in 0..=1",
                s.moving
            ));
        }
        for (field, n) in [
            ("max_abs_8bit", s.max_abs_8bit),
            ("max_temporal_8bit", s.max_temporal_8bit),
        ] {
            if n > 255 {
                return Err(format!(
                    "`sequence_summary.{field}` is {n}: 8-bit differences are 0 to 255"
                ));
            }
        }
        for (field, v) in [
            ("first_rmse_8bit", s.first_rmse_8bit),
            ("last_rmse_8bit", s.last_rmse_8bit),
        ] {
            if !(v.is_finite() && (0.0..=s.max_abs_8bit as f64).contains(&v)) {
                return Err(format!(
                    "`sequence_summary.{field}` is {v}: an 8-bit RMSE is finite, 0 or more and at most the largest error ({})",
                    s.max_abs_8bit
                ));
            }
        }
    }
    for (field, path, what, folder, ext) in [
        (
            "images.animation",
            &c.images.animation,
            "a sequence's animation",
            "images",
            ".gif",
        ),
        (
            "images.frames_plot",
            &c.images.frames_plot,
            "a sequence's plot",
            "plots",
            ".svg",
        ),
    ] {
        if let Some(path) = path {
            result_file_path(path, what, folder, ext)
                .map_err(|why| format!("`{field}` is `{path}`: {why}"))?;
        }
    }
    Ok(())
}

/// A time in milliseconds: finite, 0 or more, at most [`MAX_MS`].
fn time(field: &str, v: Option<f64>) -> Result<f64, String> {
    match v {
        Some(ms) if ms.is_finite() && (0.0..=MAX_MS).contains(&ms) => Ok(ms),
        Some(ms) => Err(format!(
            "`{field}` is {}: a time is a finite number of milliseconds in 0..={MAX_MS:e}",
            if ms.abs() >= MAX_MS {
                format!("{ms:e}")
            } else {
                ms.to_string()
            }
        )),
        None => Err(format!("`{field}` is not a number of milliseconds")),
    }
}

/// An image path as a run writes it: `images/NAME.png`, nothing else (no `..`, no absolute
/// path, no folder other than `images`).
pub fn image_path(path: &str) -> Result<(), String> {
    result_file_path(path, "an image", "images", ".png")
}

/// The path of `what`, as a run writes it: `FOLDER/NAME.EXT` (`ext` with its dot), nothing
/// else.
fn result_file_path(path: &str, what: &str, folder: &str, ext: &str) -> Result<(), String> {
    let parts: Vec<Component> = Path::new(path).components().collect();
    let plain = matches!(parts.as_slice(), [Component::Normal(dir), Component::Normal(name)]
        if *dir == folder && name.to_str().is_some_and(|n| n.ends_with(ext) && !n.contains('\\')));
    if plain && !path.contains("//") && !path.ends_with('/') {
        Ok(())
    } else {
        Err(format!(
            "{what} of a result folder is `{folder}/NAME{ext}`, inside that folder"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::image_path;

    #[test]
    fn only_plain_image_paths_pass() {
        assert!(image_path("images/a@b.png").is_ok());
        for bad in [
            "../../x/y.png",
            "/etc/passwd",
            "images/../results.json",
            "images/../../x.png",
            "images/sub/a.png",
            "plots/a.png",
            "images/a.svg",
            "./images/a.png",
            "images//a.png",
        ] {
            assert!(image_path(bad).is_err(), "{bad}");
        }
    }
}
