//! WGSL snapshots: one per distinct composed shader. Every pass of every variant is composed
//! (a shading pass also instrumented, as `<pass>.counting`), and equal WGSL is one snapshot,
//! named after its pass and a hash of its text (`name`); the index (`users.txt`) lists the
//! variants that share each. A new variant then joins existing snapshots (changing only the
//! index) or adds its own, and renames none; a change to a module shows as each shader it
//! reaches, under its new name, with the old ones left to delete.

use crate::compose::{Composer, SceneFeatures, frame_features, passes};
use crate::variant::{LoadedVariant, Msaa, MsaaResolve};

/// The folder of the WGSL snapshots, under the snapshot folder.
pub const FOLDER: &str = "wgsl";

/// The index of which variants compose each snapshot, in [`FOLDER`].
pub const INDEX: &str = "users.txt";

/// The index's first line: it says what wrote it, and marks the file as one the flow may
/// write again.
pub const INDEX_HEADER: &str =
    "# The variants composing each WGSL snapshot, written by `clusterlab snapshot`.\n";

/// A distinct composed shader: its pass (`forward`, `forward.counting`), its WGSL, and the
/// variants that compose it, in the order they were given.
pub struct Shader {
    pub pass: String,
    pub wgsl: String,
    pub users: Vec<String>,
}

impl Shader {
    /// The snapshot's name: its pass and the first 32 bits of the SHA-256 of its text (line
    /// ends made `\n`, so a checkout's line ends do not rename it).
    pub fn name(&self) -> String {
        let hash = crate::compose::sha256_hex(&self.wgsl.replace("\r\n", "\n"));
        format!("{}@{}", self.pass, &hash[..8])
    }

    /// The snapshot file's text, as insta writes it.
    pub fn file(&self) -> String {
        super::format::insta_text(
            "tests/compose.rs",
            &format!("pass `{}`", self.pass),
            "wgsl",
            &self.wgsl,
        )
    }
}

/// The variants whose shaders are snapshot: `variants`, and where the default matrix's MSAA
/// group is among them, those at 4 samples (the tonemapped resolve on one forward and one
/// deferred pipeline as well): the multisampled shaders the matrix runs.
pub fn with_multisampled(variants: &[LoadedVariant]) -> Vec<LoadedVariant> {
    let mut out = variants.to_vec();
    for (i, name) in crate::matrix::MSAA_GROUP.iter().enumerate() {
        let Some(v) = variants.iter().find(|v| v.name == *name) else {
            continue;
        };
        let resolves: &[MsaaResolve] = match i {
            1 | 2 => &[MsaaResolve::Box, MsaaResolve::Tonemapped],
            _ => &[MsaaResolve::Box],
        };
        for &resolve in resolves {
            let mut v = v.clone();
            v.variant.msaa = Msaa {
                samples: 4,
                resolve,
            };
            v.name = format!("{name}[msaa=4,{resolve:?}]");
            out.push(v);
        }
    }
    out
}

/// Every distinct shader the passes of `variants` compose, in the order first met.
pub fn distinct(composer: &Composer, variants: &[LoadedVariant]) -> Result<Vec<Shader>, String> {
    let mut shaders: Vec<Shader> = Vec::new();
    // A shading pass also as an instrumented frame composes it: the counting code behind
    // every evaluation count a table prints.
    let instrumented = frame_features(
        SceneFeatures {
            spots: true,
            ..Default::default()
        },
        Some(false),
    );
    for loaded in variants {
        for pass in passes(&loaded.variant) {
            let versions = [(pass.name().to_string(), &[][..])].into_iter().chain(
                pass.id
                    .is_shading()
                    .then(|| (format!("{}.counting", pass.name()), &instrumented[..])),
            );
            for (name, overrides) in versions {
                let wgsl = composer
                    .compose_with(&loaded.variant, &pass, overrides)
                    .map_err(|e| format!("{}: {e}", loaded.path.display()))?
                    .wgsl;
                match shaders
                    .iter_mut()
                    .find(|s| s.pass == name && s.wgsl == wgsl)
                {
                    Some(s) => s.users.push(loaded.name.clone()),
                    None => shaders.push(Shader {
                        pass: name,
                        wgsl,
                        users: vec![loaded.name.clone()],
                    }),
                }
            }
        }
    }
    Ok(shaders)
}

/// The index: [`INDEX_HEADER`], then a line per snapshot file naming the variants that
/// compose it, sorted.
pub fn index(shaders: &[Shader]) -> String {
    let mut lines: Vec<String> = shaders
        .iter()
        .map(|s| format!("{}.snap: {}\n", s.name(), s.users.join(", ")))
        .collect();
    lines.sort();
    format!("{INDEX_HEADER}{}", lines.concat())
}
