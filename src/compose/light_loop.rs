//! The ways of walking a pixel's lights: one WESL unit each under
//! `shaders/shading/light_loop/`, which a shading pass imports as
//! `package::shading::light_loop::selected`, chosen here by one exhaustive match on the
//! variant, as `CullingMethod` chooses an assignment root. Their declarations are named as
//! the shared `light_loop` module's (`LoopMangler`), so a loop moved into its own file
//! composes the same WGSL.

use serde::{Deserialize, Serialize};
use wesl::syntax::{ModulePath, PathOrigin};
use wesl::{EscapeMangler, Mangler};

use crate::variant::{CullingMethod, ListUpdate, Sampler, Variant};

/// How a shading pass walks a pixel's lights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LightLoop {
    /// Every light of the pixel's list (naive forward: every light), in index order.
    #[default]
    ListWalk,
    /// Z-binning: the lights of the pixel's depth bin that its tile's mask holds.
    ZBinWalk,
    /// The still lights' list, then the moving lights' (`ListUpdate::StaticDynamic`).
    StaticDynamic,
    /// Plain Monte Carlo over the list.
    Uniform,
    /// Resampled importance sampling over the list.
    Ris,
    /// RIS with ReSTIR's temporal reuse of the previous frame's reservoir.
    RestirTemporal,
    /// RIS with ReSTIR's temporal and spatial reuse of the previous frame's reservoirs.
    RestirSpatiotemporal,
    /// Stochastic light culling's roulette over the list.
    StochasticCulling,
}

/// The module path a shading pass imports its loop by.
const SELECTED: [&str; 3] = ["shading", "light_loop", "selected"];

impl LightLoop {
    pub const ALL: [LightLoop; 8] = [
        LightLoop::ListWalk,
        LightLoop::ZBinWalk,
        LightLoop::StaticDynamic,
        LightLoop::Uniform,
        LightLoop::Ris,
        LightLoop::RestirTemporal,
        LightLoop::RestirSpatiotemporal,
        LightLoop::StochasticCulling,
    ];

    /// The modules under `shading/light_loop/` that units share: cut from
    /// `light_loop.wesl`, they keep its names.
    pub const HELPERS: [&str; 2] = ["counters", "reservoir"];

    /// The loop variant `v` shades with.
    pub fn of(v: &Variant) -> Self {
        match v.shading.lights.sampling().map(|s| s.method) {
            Some(Sampler::Uniform { .. }) => LightLoop::Uniform,
            Some(Sampler::Ris { temporal: None, .. }) => LightLoop::Ris,
            Some(Sampler::Ris {
                temporal: Some(_),
                spatial: None,
                ..
            }) => LightLoop::RestirTemporal,
            Some(Sampler::Ris {
                temporal: Some(_),
                spatial: Some(_),
                ..
            }) => LightLoop::RestirSpatiotemporal,
            Some(Sampler::StochasticCulling { .. }) => LightLoop::StochasticCulling,
            None if !v.pipeline.is_clustered() => LightLoop::ListWalk,
            None => match (v.clusters().method(), v.clusters().update) {
                (CullingMethod::ZBinning, _) => LightLoop::ZBinWalk,
                (_, ListUpdate::StaticDynamic) => LightLoop::StaticDynamic,
                (
                    CullingMethod::OneLevel
                    | CullingMethod::TwoLevel { .. }
                    | CullingMethod::Rasterised
                    | CullingMethod::Bvh,
                    ListUpdate::Rebuild | ListUpdate::Patch | ListUpdate::Refit,
                ) => LightLoop::ListWalk,
            },
        }
    }

    /// Its file under `shaders/shading/light_loop/`, without `.wesl`.
    pub fn file(self) -> &'static str {
        match self {
            LightLoop::ListWalk => "list_walk",
            LightLoop::ZBinWalk => "zbin_walk",
            LightLoop::StaticDynamic => "static_dynamic",
            LightLoop::Uniform => "uniform",
            LightLoop::Ris => "ris",
            LightLoop::RestirTemporal => "restir_temporal",
            LightLoop::RestirSpatiotemporal => "restir_spatiotemporal",
            LightLoop::StochasticCulling => "stochastic_culling",
        }
    }

    /// Where `path` is the selected loop, the path of this loop's file.
    pub fn file_path(self, path: &ModulePath) -> Option<ModulePath> {
        let selected = matches!(path.origin, PathOrigin::Absolute) && path.components == SELECTED;
        selected.then(|| ModulePath {
            origin: PathOrigin::Absolute,
            components: vec![
                SELECTED[0].to_string(),
                SELECTED[1].to_string(),
                self.file().to_string(),
            ],
        })
    }
}

/// WESL's own mangling, but the selected unit and the helpers under `shading/light_loop/`
/// named as `light_loop` itself: a unit and the module it was cut from give their
/// declarations the same names. Another unit imported by its own path (a unit that builds
/// on another's declarations) keeps its own, so that its `shade` and the selected one's
/// never share a name.
pub struct LoopMangler;

impl Mangler for LoopMangler {
    fn mangle(&self, path: &ModulePath, item: &str) -> String {
        let within = matches!(path.origin, PathOrigin::Absolute)
            && path.components.len() == 3
            && path.components[..2] == SELECTED[..2]
            && (path.components[2] == SELECTED[2]
                || LightLoop::HELPERS.contains(&path.components[2].as_str()));
        if within {
            let shared = ModulePath {
                origin: PathOrigin::Absolute,
                components: path.components[..2].to_vec(),
            };
            return EscapeMangler.mangle(&shared, item);
        }
        EscapeMangler.mangle(path, item)
    }
}
